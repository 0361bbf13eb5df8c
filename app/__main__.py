"""``python -m app`` is the ``pbs`` command."""

from app.cli import main

raise SystemExit(main())
