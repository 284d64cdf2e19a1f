"""One module per `weldseam` command; `cli.py` registers them. Heavy imports stay inside the commands."""
