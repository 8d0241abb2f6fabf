"""The installed entry points and versions, read through a cache: the same answers as
``importlib.metadata`` (which the cached run does not import), and a distribution installed,
edited or removed is seen at the next start."""

from __future__ import annotations

import importlib.metadata as md
import json
import os
import subprocess
import sys

from odsuite.domain import installed

GROUP = "odsuite_test_group"
ASK = ("import json, sys; from odsuite.domain import installed\n"
       "eps = [[e.name, e.value, e.dist_name, e.dist_version] for e in installed.entry_points(sys.argv[1])]\n"
       "print(json.dumps([eps, installed.version('odsuite'), 'importlib.metadata' in sys.modules]))")


def _ask(tmp_path, site, group=GROUP, cache=None):
    env = {**os.environ, "ODSUITE_CACHE_DIR": str(cache or tmp_path / "cache"), "PYTHONPATH": str(site)}
    out = subprocess.run([sys.executable, "-c", ASK, group], capture_output=True, text=True, env=env,
                         cwd=tmp_path, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def _dist(site, name, entry_points: str):
    """A distribution as pip lays it out: a .dist-info folder with METADATA and entry_points.txt."""
    info = site / f"{name}-1.0.dist-info"
    info.mkdir(parents=True, exist_ok=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(entry_points)
    return info


def _stepped(path):
    """Moves a file's time a second on: an edit within the file system's time resolution."""
    t = os.stat(path).st_mtime_ns + 1_000_000_000
    os.utime(path, ns=(t, t))


def test_cached_answers_are_importlib_metadatas_without_importing_it(tmp_path):
    site = tmp_path / "site"
    _dist(site, "lab_a", f"[{GROUP}]\nfirst = lab_a.plugin:Hooks.inner\nsecond = lab_a\n")
    first = _ask(tmp_path, site)
    again = _ask(tmp_path, site)
    assert first[:2] == again[:2] and (first[2], again[2]) == (True, False)
    assert first[0] == [["first", "lab_a.plugin:Hooks.inner", "lab_a", "1.0"], ["second", "lab_a", "lab_a", "1.0"]]
    assert first[1] == md.version("odsuite")
    # the installed odsuite group, as importlib.metadata gives it in this process
    truth = [[e.name, e.value, e.dist.name, e.dist.version] for e in md.entry_points(group="odsuite")]
    assert _ask(tmp_path, site, "odsuite")[0] == truth and len(truth) >= 9
    assert _ask(tmp_path, site, "odsuite") == [truth, md.version("odsuite"), False]


def test_a_distribution_installed_edited_or_removed_is_seen(tmp_path):
    site = tmp_path / "site"
    _dist(site, "lab_a", f"[{GROUP}]\na = lab_a\n")
    assert _ask(tmp_path, site)[0] == [["a", "lab_a", "lab_a", "1.0"]]
    b = _dist(site, "lab_b", f"[{GROUP}]\nb = lab_b:hooks\n")
    assert _ask(tmp_path, site)[0] == [["a", "lab_a", "lab_a", "1.0"], ["b", "lab_b:hooks", "lab_b", "1.0"]]
    (b / "entry_points.txt").write_text(f"[{GROUP}]\nb2 = lab_b:other\n")  # edited in place
    _stepped(b / "entry_points.txt")
    assert [e[:2] for e in _ask(tmp_path, site)[0]] == [["a", "lab_a"], ["b2", "lab_b:other"]]
    for f in b.iterdir():
        f.unlink()
    b.rmdir()
    assert _ask(tmp_path, site)[0] == [["a", "lab_a", "lab_a", "1.0"]]
    assert _ask(tmp_path, site)[2] is False  # and the cache holds again


def test_a_broken_or_unwritable_cache_only_costs_the_reading(tmp_path):
    site = tmp_path / "site"
    _dist(site, "lab_a", f"[{GROUP}]\na = lab_a\n")
    first = _ask(tmp_path, site)
    (cache,) = (tmp_path / "cache").iterdir()
    cache.write_text('{"key": [1, "half a')
    assert _ask(tmp_path, site) == first  # read again and written whole
    assert _ask(tmp_path, site)[2] is False
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    assert _ask(tmp_path, site, cache=blocked / "cache") == first
    assert _ask(tmp_path, site, cache=blocked / "cache") == first


def test_entry_point_load_follows_importlib_metadata():
    for value in ("os.path:join", "json", "os:path.join", "collections.abc:Mapping [extra]", "json [x]"):
        ours = installed.EntryPoint("n", value, "d", "1").load()
        assert ours is md.EntryPoint("n", value, "g").load(), value



def test_cache_answers_of_wrong_types_are_read_again(tmp_path):
    """A cache whose key matches but whose answers are not what was written (hand-edited, written
    by another version) is read again, not trusted into a traceback."""
    site = tmp_path / "site"
    _dist(site, "forgedpkg", f"[{GROUP}]\nx = forgedpkg.mod:thing\n")
    first = _ask(tmp_path, site)
    assert first[0] == [["x", "forgedpkg.mod:thing", "forgedpkg", "1.0"]]
    (cache,) = (tmp_path / "cache").glob("installed-*.json")
    for forged in (5, [5], [["x"]], [[1, 2, 3, 4]], {"a": 1}):
        doc = json.loads(cache.read_text())
        doc["answers"] = {k: forged for k in doc["answers"]}
        cache.write_text(json.dumps(doc))
        assert _ask(tmp_path, site)[:2] == first[:2], forged


def test_relative_cache_dir_writes_nothing_into_the_working_folder(tmp_path):
    """``$ODSUITE_CACHE_DIR`` relative is ignored (as XDG's rule for its variables): a cache
    follows no working folder into a project's or a user's files."""
    site = tmp_path / "site"
    _dist(site, "relpkg", f"[{GROUP}]\ny = relpkg:z\n")
    work = tmp_path / "work"
    work.mkdir()
    env = {**os.environ, "ODSUITE_CACHE_DIR": "rel-cache", "XDG_CACHE_HOME": str(tmp_path / "xdg"),
           "PYTHONPATH": str(site)}
    out = subprocess.run([sys.executable, "-c", ASK, GROUP], capture_output=True, text=True, env=env,
                         cwd=work, timeout=120)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)[0] == [["y", "relpkg:z", "relpkg", "1.0"]]
    assert list(work.iterdir()) == []
    assert list((tmp_path / "xdg" / "odsuite").glob("installed-*.json"))
