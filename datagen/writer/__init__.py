"""Dataset writers: the MQTT writer process (``dataset_writer``) and how it keeps samples
(``durable_samples``), writes, journals, locks and finalizes shards. The shard format that
readers share: ``datagen.shards``."""
