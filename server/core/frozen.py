"""A quicker constructor for the frozen dataclasses the 1 kHz tick builds every tick.

A frozen dataclass's generated ``__init__`` sets each field through ``object.__setattr__`` (its
own ``__setattr__`` refuses): ~0.75 µs for ten fields on CPython 3.11, three times a tick (the
scenario's context and output, the tick's result). ``quick_init`` gives the class an ``__init__``
with the same signature (positional order, defaults, default factories) that writes the instance
dict directly, ~0.26 µs; for a slotted class, each slot through its descriptor (a tracker
sample's record, server/ipc/records.py: 0.9 → 0.5 µs). Everything else stays the dataclass's: the
instances are still frozen (assignment raises FrozenInstanceError), compare, print and
``dataclasses.replace`` as before.
"""

from __future__ import annotations

import dataclasses

_MISSING = object()  # "not given" for a field with a default factory


def quick_init(cls: type) -> type:
    """Replace the generated ``__init__`` of frozen dataclass ``cls`` (no ``__post_init__``, no
    init=False or keyword-only fields) by a direct one."""
    params = dataclasses.fields(cls)
    if not cls.__dataclass_params__.frozen or hasattr(cls, "__post_init__"):
        raise TypeError(f"quick_init is for frozen dataclasses without __post_init__: {cls.__name__}")
    slotted = "__slots__" in cls.__dict__
    env: dict = {"_MISSING": _MISSING}
    args, body = [], []
    for f in params:
        if not f.init or f.kw_only:
            raise TypeError(f"quick_init: field {f.name} of {cls.__name__} is init=False or keyword-only")
        if slotted:
            env[f"_s_{f.name}"] = cls.__dict__[f.name].__set__
        store = f"_s_{f.name}(self, " if slotted else f"d[{f.name!r}] = ("
        if f.default is not dataclasses.MISSING:
            env[f"_d_{f.name}"] = f.default
            args.append(f"{f.name}=_d_{f.name}")
            body.append(f"    {store}{f.name})")
        elif f.default_factory is not dataclasses.MISSING:
            env[f"_f_{f.name}"] = f.default_factory
            args.append(f"{f.name}=_MISSING")
            body.append(f"    {store}_f_{f.name}() if {f.name} is _MISSING else {f.name})")
        else:
            args.append(f.name)
            body.append(f"    {store}{f.name})")
    first = "    pass\n" if slotted else "    d = self.__dict__\n"
    source = f"def __init__(self, {', '.join(args)}):\n" + first + "\n".join(body) + "\n"
    exec(source, env)  # noqa: S102 - our own text, built from the class's field names only
    init = env["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    init.__doc__ = cls.__init__.__doc__
    cls.__init__ = init
    return cls
