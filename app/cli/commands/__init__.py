"""`wiithrow` subcommands, one module each (see wiithrow.app.cli.main)."""
