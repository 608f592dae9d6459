"""``python -m jellysim ...``: the same command line as the ``jellysim`` script."""
from .cli import cli

if __name__ == "__main__":
    cli(prog_name="jellysim")
