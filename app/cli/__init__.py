"""The `wiithrow` command line (`main`), its subcommands (`commands`), the benchmarks behind
`wiithrow bench` (`bench`) and the terminal glue they share. The top layer: the only one that
may import the dashboard (`wiithrow.web`).
"""

from wiithrow.app.cli.main import main

__all__ = ["main"]
