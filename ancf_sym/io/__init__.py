"""Files in and out: scene files (`scene_toml`, the one TOML reader), result folders written only by finished runs
(`result_dir`), result.json (`json_out`, `dynamics_output`), PNG plots and animations (`plots`), VTK (`vtk`)."""
