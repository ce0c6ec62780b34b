"""The API reference page documents every module of every layer, in the order of the data
flow (the book builds it with -W, so a broken docstring fails the build)."""
import re
from pathlib import Path

from test_layers import LAYERS, MODULES

ROOT = Path(__file__).resolve().parents[1]


def test_the_api_page_has_every_public_module_in_layer_order():
    page = (ROOT / "book" / "api.md").read_text()
    documented = re.findall(r"\.\. automodule:: (\S+)", page)
    public = {m for m in MODULES
              if len(m.split(".")) > 2 and m.split(".")[1] in LAYERS
              and not any(p.startswith("_") for p in m.split(".")[2:])}
    assert public <= set(documented), sorted(public - set(documented))
    layer_of = [LAYERS.index(m.split(".")[1]) for m in documented]
    assert layer_of == sorted(layer_of)  # core first, report last
    assert "file: api" in (ROOT / "book" / "_toc.yml").read_text()
