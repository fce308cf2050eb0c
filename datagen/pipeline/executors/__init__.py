"""Where scene workers run: ``base`` (the interface), ``local_processes``, ``ray_actors``; chosen
by name through ``datagen.registries.EXECUTORS``."""
