"""diagnose leaves the objects that exist before it out of the collector's full passes, and the
caller's own frozen objects as the caller froze them."""

import gc

from odsuite.diagnosis.diagnose import _outliving_left_alone


def test_the_callers_objects_are_frozen_during_diagnose_and_unfrozen_after():
    gc.unfreeze()
    kept = [object() for _ in range(1000)]
    assert gc.get_freeze_count() == 0
    with _outliving_left_alone():
        assert gc.get_freeze_count() >= len(kept)
    assert gc.get_freeze_count() == 0


def test_a_caller_that_froze_its_objects_keeps_them_frozen_and_nothing_more():
    gc.unfreeze()
    gc.freeze()  # as the command line does at start
    try:
        frozen = gc.get_freeze_count()
        assert frozen > 0
        made = [[object()] for _ in range(1000)]  # alive at the call, made after the caller froze
        with _outliving_left_alone():
            assert gc.get_freeze_count() == frozen
        assert gc.get_freeze_count() == frozen and made
    finally:
        gc.unfreeze()


def test_diagnose_runs_with_the_callers_objects_frozen(monkeypatch):
    import odsuite.diagnosis.diagnose as diagnose_module

    gc.unfreeze()
    seen = []

    def inner(*args):
        seen.append(gc.get_freeze_count())
        raise RuntimeError("stop here")

    monkeypatch.setattr(diagnose_module, "_diagnose", inner)
    try:
        diagnose_module.diagnose(object(), workers=1)
    except RuntimeError:
        pass
    assert seen and seen[0] > 0 and gc.get_freeze_count() == 0


def test_an_error_inside_unfreezes_too():
    gc.unfreeze()
    try:
        with _outliving_left_alone():
            raise ValueError("inside")
    except ValueError:
        pass
    assert gc.get_freeze_count() == 0
