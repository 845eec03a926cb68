"""Former entry point of the per-stage table: now :mod:`benchmarks.run`.

    .venv/bin/python -m benchmarks.stages [CASE ...]   # same as python -m benchmarks
"""
import sys

from .run import main

if __name__ == "__main__":
    sys.exit(main())
