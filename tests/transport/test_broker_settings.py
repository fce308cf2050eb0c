"""A broker's settings record and its saved credentials: pure checks (no Mosquitto)."""

from dataclasses import replace
from pathlib import Path

import pytest

from datagen.transport.broker_credentials import (
    CREDENTIALS_FILE,
    CredentialsFileError,
    broker_credentials,
)
from datagen.transport.broker_settings import BrokerSettings, service_settings


def test_settings_are_validated_when_made_and_when_changed():
    with pytest.raises(ValueError, match="tls_cert and tls_key go together"):
        BrokerSettings(tls_cert="server.crt")
    with pytest.raises(ValueError, match="port is 70000; expected 1-65535 or None"):
        BrokerSettings(port=70000)
    with pytest.raises(ValueError, match="max_queued_bytes is 0; expected > 0"):
        replace(BrokerSettings(), max_queued_bytes=0)  # checked again when changed
    with pytest.raises(ValueError, match="startup_timeout_s is -1; expected > 0"):
        BrokerSettings(startup_timeout_s=-1)
    settings = BrokerSettings(acl_file="acl", data_dir="state")
    assert settings.acl_file == Path("acl") and settings.data_dir == Path("state")
    assert not settings.tls and BrokerSettings(tls_cert="c", tls_key="k").tls


def test_a_long_lived_broker_with_tls_serves_tls_on_the_port_it_is_given():
    plain = service_settings(port=1883)
    assert (plain.port, plain.tls_port, plain.autosave_interval_s) == (1883, None, 30)
    tls = service_settings(port=8883, tls_cert="c.pem", tls_key="k.pem")
    assert (tls.port, tls.tls_port) == (None, 8883)


def test_generated_credentials_are_kept_in_the_data_dir_and_read_back(tmp_path):
    first = broker_credentials(tmp_path, None, None)
    assert (tmp_path / CREDENTIALS_FILE).stat().st_mode & 0o077 == 0
    assert broker_credentials(tmp_path, None, None) == first
    assert broker_credentials(tmp_path, first[0], None) == first
    assert broker_credentials(tmp_path, "given", "pw") == ("given", "pw")
    assert broker_credentials(None, None, None) != broker_credentials(None, None, None)


@pytest.mark.parametrize(
    "text", ["{cut sh", "[]", '{"username": "u"}', '{"username": "", "password": "p"}', "x" * 5000]
)
def test_a_damaged_credentials_file_is_one_clear_error_naming_it(tmp_path, text):
    (tmp_path / CREDENTIALS_FILE).write_text(text)
    with pytest.raises(CredentialsFileError, match=f"{CREDENTIALS_FILE}: expected the broker's"):
        broker_credentials(tmp_path, None, None)
