"""odsuite built-in plugin: models, physical effects and the rigs they describe."""

from pathlib import Path

from odsuite import hookimpl
from odsuite.core.rig import load_rig

RIG_DIR = Path(__file__).with_name("rigs")


@hookimpl
def odsuite_register_rigs(registry):
    for path in sorted(RIG_DIR.glob("*.toml")):
        rig = load_rig(path)
        registry.add(rig.name, rig)
