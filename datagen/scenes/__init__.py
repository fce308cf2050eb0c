"""Scene families: one module each, with ``produce(config, seed, index, attempt) -> Sample``.
They are found through ``datagen.registries.FAMILIES`` (docs/extending.md adds one)."""
