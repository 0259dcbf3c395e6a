"""docs/python.md quotes the example scripts CI runs, so they cannot drift apart."""

from __future__ import annotations


from conftest import REPO

EXAMPLES = REPO / "python" / "examples"


def test_the_docs_quote_every_example_verbatim():
    doc = (REPO / "docs" / "python.md").read_text()
    examples = sorted(EXAMPLES.glob("*.py"))
    assert examples
    for path in examples:
        assert path.read_text().strip() in doc, f"{path.name} is not quoted in docs/python.md"


def test_the_readme_gives_the_install_command():
    assert "pip install ./python" in (REPO / "README.md").read_text()
