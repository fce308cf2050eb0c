"""Formats exported from a finished dataset's shards, one module each, listed in
``datagen.registries.EXPORTS`` and run by ``runner.run_exports``."""
