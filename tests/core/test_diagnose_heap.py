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


def test_a_caller_that_froze_its_objects_keeps_them_frozen():
    gc.unfreeze()
    gc.freeze()  # as the command line does at start
    try:
        frozen = gc.get_freeze_count()
        with _outliving_left_alone():
            pass
        assert gc.get_freeze_count() >= frozen > 0
    finally:
        gc.unfreeze()


def test_an_error_inside_unfreezes_too():
    gc.unfreeze()
    try:
        with _outliving_left_alone():
            raise ValueError("inside")
    except ValueError:
        pass
    assert gc.get_freeze_count() == 0
