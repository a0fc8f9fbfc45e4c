"""Settings from an environ mapping."""

import pytest

from guided_sfm.settings import Settings, SettingsError


def test_defaults_are_the_embedded_mode(tmp_path):
    settings = Settings.from_env({"GUIDED_SFM_DATA_DIR": str(tmp_path)})
    assert settings.database_url == f"sqlite:///{tmp_path / 'guided_sfm.db'}"
    assert settings.broker_url == "filesystem://" and settings.broker_dir == tmp_path / "broker"
    assert settings.threads == 2 and settings.open_signup and settings.secret_key is None


def test_values_are_parsed_and_validated(tmp_path):
    env = {"GUIDED_SFM_DATA_DIR": str(tmp_path), "GUIDED_SFM_THREADS": "4", "GUIDED_SFM_OPEN_SIGNUP": "false",
           "GUIDED_SFM_MAX_UPLOAD_MB": "10", "GUIDED_SFM_BROKER_URL": "redis://h:6379/1",
           "GUIDED_SFM_DATABASE_URL": "postgresql+psycopg://u@h/db"}
    settings = Settings.from_env(env)
    assert (settings.threads, settings.open_signup, settings.max_upload_bytes) == (4, False, 10 << 20)
    for key, value in [("THREADS", "two"), ("OPEN_SIGNUP", "maybe"), ("DATABASE_URL", "mysql://x"),
                       ("BROKER_URL", "amqp://x"), ("THREADS", "0"), ("SECRET_KEY", "short")]:
        with pytest.raises(SettingsError, match=key):
            Settings.from_env({**env, f"GUIDED_SFM_{key}": value})


def test_secret_is_generated_once_and_private(tmp_path):
    settings = Settings.from_env({}, data_dir=tmp_path)
    first, second = settings.with_secret(), settings.with_secret()
    assert first.secret_key == second.secret_key and len(first.secret_key) > 32
    assert (tmp_path / "secret_key").stat().st_mode & 0o777 == 0o600


NUMERIC = {"THREADS": ("3", 3), "MAX_UPLOAD_MB": ("5", 5), "TOKEN_MINUTES": ("9", 9),
           "MAX_ATTEMPTS": ("4", 4), "SWEEP_SECONDS": ("1.5", 1.5), "HEARTBEAT_SECONDS": ("2.5", 2.5),
           "STALE_SECONDS": ("7.5", 7.5), "REQUEUE_SECONDS": ("8", 8.0)}


def test_every_numeric_setting_is_read_from_its_variable(tmp_path):
    env = {f"GUIDED_SFM_{key}": raw for key, (raw, _) in NUMERIC.items()}
    settings = Settings.from_env({"GUIDED_SFM_DATA_DIR": str(tmp_path), **env})
    assert {key: getattr(settings, key.lower()) for key in NUMERIC} == {k: v for k, (_, v) in NUMERIC.items()}
    assert type(settings.threads) is int and type(settings.requeue_seconds) is float


@pytest.mark.parametrize("key", sorted(NUMERIC))
def test_a_bad_number_names_its_variable(tmp_path, key):
    expected = "an integer" if isinstance(NUMERIC[key][1], int) else "a number"
    for raw in ("lots", "1.5x") if expected == "a number" else ("lots", "1.5"):
        with pytest.raises(SettingsError, match=f"GUIDED_SFM_{key} must be {expected}, got '{raw}'"):
            Settings.from_env({"GUIDED_SFM_DATA_DIR": str(tmp_path), f"GUIDED_SFM_{key}": raw})
