"""Compiling and the first run: what a command compiles, when it runs a reference meanwhile, the
warm-up and the detached background compile (docs/speed.md "First run")."""
