"""The scene made numeric: nodes and coordinates (`mesh`, with Probe), one energy term per (element, effect)
(`terms`), dead loads and point masses (`loads`), supports and joints as constraint rows (`constraints`), the
assembled potential with its exact gradient and Hessian (`assembly`), the reduced coordinates (`reduced`), fields
along members for outputs (`fields`)."""
