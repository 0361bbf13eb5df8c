"""``python -m app.bench`` runs the bench (``pbs bench`` once the CLI wires it in)."""

from app.bench import main

raise SystemExit(main())
