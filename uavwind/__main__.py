"""``python -m uavwind``: the command line of :mod:`uavwind.cli`."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main(program=True))
