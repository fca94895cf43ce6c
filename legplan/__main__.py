"""`python -m legplan ...`: the `legplan` command."""

from legplan.cli.main import main

main()
