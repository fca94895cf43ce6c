"""`python -m legplan ...`: the `legplan` command."""

from legplan.cli.main import main

if __name__ == "__main__":
    main()
