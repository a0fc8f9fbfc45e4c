"""Migrations are the schema: they match the models, and go down and up again on the test database."""

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect

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


def schema(url: str) -> dict:
    """Tables with their columns, keys, indexes and checks, and the Alembic revision: what a
    down-and-up must give back exactly as a fresh upgrade made it."""
    engine = make_engine(url)
    inspector = inspect(engine)
    tables = {}
    for table in sorted(inspector.get_table_names()):
        tables[table] = {
            "columns": [(c["name"], str(c["type"]), c["nullable"], str(c.get("default")))
                        for c in inspector.get_columns(table)],
            "primary": inspector.get_pk_constraint(table)["constrained_columns"],
            "foreign": sorted((f["name"] or "", tuple(f["constrained_columns"]), f["referred_table"])
                              for f in inspector.get_foreign_keys(table)),
            "unique": sorted((u["name"] or "", tuple(u["column_names"]))
                             for u in inspector.get_unique_constraints(table)),
            "indexes": sorted((i["name"] or "", tuple(i["column_names"]), bool(i["unique"]))
                              for i in inspector.get_indexes(table)),
            "checks": sorted((c["name"] or "", c["sqltext"]) for c in inspector.get_check_constraints(table)),
        }
    with engine.connect() as connection:
        revision = MigrationContext.configure(connection).get_current_revision()
    engine.dispose()
    return {"tables": tables, "revision": revision}


def test_downgrade_and_upgrade_again_gives_the_same_schema(tmp_path):
    url, drop = create_database(tmp_path)
    try:
        fresh = schema(url)
        assert {"users", "projects", "jobs"} <= set(fresh["tables"]) and fresh["revision"]
        downgrade(url, "-1")
        one_down = schema(url)
        assert one_down != fresh  # the last migration's downgrade changed something
        upgrade(url)
        assert schema(url) == fresh
        downgrade(url, "base")
        base = schema(url)
        assert set(base["tables"]) <= {"alembic_version"} and base["revision"] is None
        upgrade(url)
        assert schema(url) == fresh
    finally:
        drop()
