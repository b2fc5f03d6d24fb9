"""`wiithrow` subcommands, one module each (see app.cli)."""
