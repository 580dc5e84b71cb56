"""CLI subcommands, one module per stage; each exposes ``register(app)``. Heavy imports stay inside commands."""
