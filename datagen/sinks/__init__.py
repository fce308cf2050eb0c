"""Dataset writers: the MQTT writer process and the shard formats it writes."""
