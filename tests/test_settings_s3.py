"""The S3 endpoint setting is checked at start, where boto3 would refuse it only later."""

import pytest

from guided_sfm.settings import Settings, SettingsError

S3 = {"GUIDED_SFM_ARTIFACTS_URL": "s3://bucket/some/prefix"}


def test_the_s3_endpoint_must_be_an_http_url(tmp_path):
    env = {"GUIDED_SFM_DATA_DIR": str(tmp_path), **S3}
    for good in ("http://127.0.0.1:9000", "https://s3.example.org"):
        assert Settings.from_env({**env, "GUIDED_SFM_S3_ENDPOINT_URL": good}).s3_endpoint_url == good
    assert Settings.from_env(env).s3_endpoint_url == ""  # AWS itself
    for bad in ("minio:9000", "ftp://minio:9000", "127.0.0.1:9000"):
        with pytest.raises(SettingsError, match="S3_ENDPOINT_URL"):
            Settings.from_env({**env, "GUIDED_SFM_S3_ENDPOINT_URL": bad})
