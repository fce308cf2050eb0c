"""DataTransfer engine: samples out to the broker, acknowledgements and writer status back.

- ``wire``: the binary format of one sample (docs/wire-format.md)
- ``topics``: a build's topics and the ack schema
- ``publisher``: ``SamplePublisher``, samples to the broker in a bounded window
- ``collector``: ``AckCollector``, writer acks and statuses, finalize/announce commands
- ``connection``: ``MqttConnection``, the one way datagen opens an MQTT v5 connection
- ``broker_url``: parsing, building and redacting ``mqtt://`` / ``mqtts://`` URLs
- ``mosquitto``, ``mosquitto_config``: a managed Mosquitto and the files it is given

Measured Mosquitto/paho behaviour the code relies on: docs/mqtt-pitfalls.md.
"""
