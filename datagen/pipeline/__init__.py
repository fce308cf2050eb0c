"""A dataset build: ``run.run_build`` prepares the output directory and broker, the
``coordinator`` drives workers (``executors/``, ``worker``) and writers until exactly N samples are
durable, then the manifest."""
