"""scripts/results.py: the manifest's checks and the commands it makes of a page."""

import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import results  # noqa: E402


def write(tmp_path, text):
    p = tmp_path / "pages.toml"
    p.write_text(text)
    return str(p)


def test_the_committed_manifest_loads_and_every_page_has_a_plan():
    pages = results.load()
    assert "nightly" in pages
    for name in pages:
        argvs, outs = results.plan(pages, name, "mapbench", "reports/results")
        assert argvs, name
        assert all(o.startswith(f"reports/results/{name}/") for o in outs)


def test_a_batch_becomes_a_run_with_its_options_and_two_of_one_config_are_numbered(tmp_path):
    pages = results.load(write(tmp_path, """
[[page]]
name = "p"
[[page.batch]]
config = "configs/results/p.toml"
only = ["*__sd__*", "*__nh__*"]
repeat = 3
jobs = 1
[[page.batch]]
config = "configs/results/p.toml"
[[page.command]]
run = ["cargo", "bench", "--bench", "assembly"]
"""))
    argvs, outs = results.plan(pages, "p", "mb", "out")
    assert outs == ["out/p/p-1", "out/p/p-2"]
    assert argvs[0] == ["mb", "run", "configs/results/p.toml", "--out", "out/p/p-1", "--no-history",
                        "--only", "*__sd__*", "--only", "*__nh__*", "--repeat", "3", "--jobs", "1"]
    assert argvs[1] == ["mb", "run", "configs/results/p.toml", "--out", "out/p/p-2", "--no-history"]
    assert argvs[2] == ["cargo", "bench", "--bench", "assembly"]


@pytest.mark.parametrize("text, why", [
    ('[[page]]\nname = "p"\n', "nothing makes it"),
    ('[[page]]\nname = "p"\n[[page.batch]]\nonly = ["x"]\n', "needs `config`"),
    ('[[page]]\nname = "p"\n[[page.batch]]\nconfig = "c"\nrepeats = 2\n', "needs `config`"),
    ('[[page]]\nname = "p"\n[[page.command]]\nrun = []\n', "a command is"),
    ('[[page]]\nname = "p"\ncolour = 1\n[[page.command]]\nrun = ["x"]\n', "unknown keys"),
    ('[[page]]\nname = "p"\n[[page.command]]\nrun = ["x"]\n[[page]]\nname = "p"\n[[page.command]]\nrun = ["x"]\n',
     "named twice"),
])
def test_a_manifest_that_does_not_say_what_makes_a_page_is_refused(tmp_path, text, why):
    with pytest.raises(ValueError, match=why.replace("`", ".")):
        results.load(write(tmp_path, text))


def test_an_unknown_page_is_refused_with_the_list(capsys):
    assert results.main(["no-such-page"]) == 2
    assert "pages: nightly" in capsys.readouterr().err
