"""Dataset writers: the MQTT writer process (``writer``) and how it writes, journals, locks
and finalizes shards. The shard format that readers share: ``datagen.shards``."""
