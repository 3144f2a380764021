import sys

from .cli import main

if __name__ == "__main__":  # not in the worker processes a Dask LocalCluster spawns from this module
    sys.exit(main())
