"""``python -m sb3_comm.experiments FILE_OR_NAME [options]`` = ``sb3-comm experiment ...``."""

import sys

from sb3_comm.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["experiment", *sys.argv[1:]]))
