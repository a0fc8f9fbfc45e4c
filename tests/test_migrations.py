"""Migrations are the schema: they match the models, and go down and up again on the test database."""

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from guided_sfm.db.base import Base
from guided_sfm.db.migrate import downgrade, upgrade
from guided_sfm.db.session import make_engine
from tests.conftest import create_database


def test_models_match_the_migrations(database_url):
    engine = make_engine(database_url)
    with engine.connect() as connection:
        context = MigrationContext.configure(connection, opts={"compare_type": True})
        diff = compare_metadata(context, Base.metadata)
    engine.dispose()
    assert diff == []


def test_downgrade_and_upgrade_again(tmp_path):
    url, drop = create_database(tmp_path)
    try:
        downgrade(url, "base")
        upgrade(url)
    finally:
        drop()
