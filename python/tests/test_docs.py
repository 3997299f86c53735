"""docs/python.md shows the example that `make figures` runs."""

from conftest import REPO


def test_the_guide_quotes_the_example_script_whole():
    script = (REPO / "docs" / "python-sweeps.py").read_text()
    guide = (REPO / "docs" / "python.md").read_text()
    assert "```python\n" + script + "```" in guide


def test_the_readme_links_the_guide():
    assert "(docs/python.md)" in (REPO / "README.md").read_text()
