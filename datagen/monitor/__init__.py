"""The live build monitor: a static page served over HTTP that watches builds over MQTT-over-WebSockets (docs/monitor.md)."""
