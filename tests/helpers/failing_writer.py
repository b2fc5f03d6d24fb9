"""A writer process that fails before it is ready (`tests/app/test_writer_process.py`): one line on
stderr, exit status 3, never READY."""

import sys

if __name__ == "__main__":
    print("not a writer", file=sys.stderr, flush=True)
    sys.exit(3)
