"""The model contract: what a provider of ``odsuite_register_models`` is.

A model factory is called with a rig (:class:`~odsuite.domain.rig.Rig`, or None for a model that
needs none) and returns a :class:`~odsuite.domain.model.Model`: its structure (a
``LinearStructure`` giving M, K, C in SI and the rows of any point; rigid bodies, springs and
flexible modes are one family, a beam's finite elements another) and its measurement chain. A rig
file's ``default_model`` names one; bad rigs raise :class:`~odsuite.domain.errors.ConfigError`
naming the rig and field.
"""

from __future__ import annotations

from typing import Protocol

from odsuite.domain.model import Model
from odsuite.domain.rig import Rig


class ModelFactory(Protocol):
    """What every registered model is (checked when a plugin registers one)."""

    def __call__(self, rig: Rig | None) -> Model: ...


PROTOCOL = ModelFactory
