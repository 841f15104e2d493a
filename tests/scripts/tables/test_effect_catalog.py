"""docs/effects.md is the catalog's records as they are: regenerate it when a record changes."""

import effect_catalog

from euc_sim.model.catalog import CATALOG, Effect


def test_the_page_is_the_records():
    assert effect_catalog.DOC.read_text() == effect_catalog.page(), \
        "docs/effects.md is stale: python scripts/tables/effect_catalog.py"


def test_a_record_added_is_a_row_and_the_script_writes_the_page(tmp_path):
    rec = Effect("test_only_loss", "c", "W", "a loss only this test has", kind="external", bounds=(0.0, 5.0))
    assert rec.name not in CATALOG
    CATALOG.add(rec)
    try:
        row = next(r for r in effect_catalog.rows() if "`test_only_loss`" in r)
        assert "| c, W | external, 0 … 5 W |" in row
        out = tmp_path / "effects.md"
        assert effect_catalog.main(["--out", str(out)]) == 0
        assert "`test_only_loss`" in out.read_text()
    finally:
        CATALOG.remove(rec.name)
    assert "`test_only_loss`" not in "\n".join(effect_catalog.rows())
