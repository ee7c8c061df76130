"""server/core/frozen.py: quick_init keeps a frozen dataclass's constructor contract."""

import dataclasses

import pytest

from server.core.frozen import quick_init


@dataclasses.dataclass(frozen=True)
class Plain:
    a: int
    b: str = "b"
    c: dict = dataclasses.field(default_factory=dict)


@quick_init
@dataclasses.dataclass(frozen=True)
class Quick:
    a: int
    b: str = "b"
    c: dict = dataclasses.field(default_factory=dict)


@quick_init
@dataclasses.dataclass(frozen=True, slots=True)
class QuickSlotted:  # the records between the processes (server/ipc/records.py) are slotted
    a: int
    b: str = "b"
    c: dict = dataclasses.field(default_factory=dict)


@pytest.mark.parametrize("cls", [Quick, QuickSlotted])
@pytest.mark.parametrize("args, kwargs", [((1,), {}), ((1, "x"), {}), ((1,), {"c": {"k": 1}}), ((), {"a": 2, "b": "y"})])
def test_same_fields_as_the_generated_init(cls, args, kwargs):
    assert dataclasses.astuple(cls(*args, **kwargs)) == dataclasses.astuple(Plain(*args, **kwargs))


def test_a_slotted_class_keeps_its_slots():
    q = QuickSlotted(1)
    assert not hasattr(q, "__dict__") and q.c == {} and q.c is not QuickSlotted(1).c
    with pytest.raises(dataclasses.FrozenInstanceError):
        q.a = 2


def test_default_factory_gives_a_fresh_value_each_time_and_a_given_one_is_kept():
    first, second = Quick(1), Quick(1)
    assert first.c == {} and first.c is not second.c
    given = {"k": 1}
    assert Quick(1, c=given).c is given


def test_still_frozen_comparable_and_replaceable():
    q = Quick(1, "x")
    with pytest.raises(dataclasses.FrozenInstanceError):
        q.a = 2
    assert q == Quick(1, "x") and q != Quick(2, "x")
    assert dataclasses.replace(q, a=3) == Quick(3, "x")
    assert repr(q) == "Quick(a=1, b='x', c={})"


def test_missing_or_unknown_arguments_raise_like_the_generated_init():
    with pytest.raises(TypeError):
        Quick()
    with pytest.raises(TypeError):
        Quick(1, d=2)


def test_refuses_classes_it_would_get_wrong():
    @dataclasses.dataclass
    class Mutable:
        a: int

    @dataclasses.dataclass(frozen=True)
    class Checked:
        a: int

        def __post_init__(self):
            pass

    for cls in (Mutable, Checked):
        with pytest.raises(TypeError):
            quick_init(cls)
