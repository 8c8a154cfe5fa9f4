"""What every layer uses and none owns: checks of user values (SceneError), CasADi buffers and cheap MX arithmetic,
the scatter of kernel results into sparse matrices, the setup cache, interruptible runs, errors for unknown names."""
