"""``python -m sb3_comm`` runs the ``sb3-comm`` command line."""

from sb3_comm.cli import main

raise SystemExit(main())
