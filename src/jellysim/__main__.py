"""``python -m jellysim ...``: the same command line as the ``jellysim`` script."""
from .cli import main

if __name__ == "__main__":
    main()
