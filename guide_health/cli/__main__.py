"""`python -m guide_health.cli ...`: the `guide-health` command."""
import sys

from guide_health.cli.app import main

sys.exit(main())
