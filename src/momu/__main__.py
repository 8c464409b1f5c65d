"""`python -m momu` runs the `momu` command."""

from momu.cli import main

raise SystemExit(main())
