"""The layout of a kernel's coefficient or state array, declared once as a named list.

A filter's numba kernel reads its coefficients and carries its state in flat float64 arrays; which entry
holds what is the kernel's layout. :class:`Layout` declares it once, as ``(name, length, meaning)`` fields in
order, and everything else derives from it:

- the kernel's index constants: ``C = Layout("C", (("DT", 1, "s"), ("ACC_LP", 5, "b0 .. a2"), ...))`` gives
  ``C.DT == 0``, ``C.ACC_LP == 1`` and ``C.LEN``, the array's length. A layout is a module object, and numba
  reads a module's attributes as compile-time constants, so a kernel indexes ``c[C.K_MAG]`` at the cost of
  ``c[7]`` (the same machine code);
- the arrays: :meth:`Layout.pack` builds one from named values, checking that each field gets its length;
- the C port's enums and array sizes: :mod:`objectives.attitude.cexport` renders ``enum { C_DT = 0, ... }``
  and the struct members' sizes from the same object, so the C never repeats a number.
"""

from __future__ import annotations

import types
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

__all__ = ["Field", "Layout"]


@dataclass(frozen=True)
class Field:
    """One entry of a layout: ``name`` (upper case, a C identifier), its first index, its length, its meaning."""

    name: str
    offset: int
    size: int
    doc: str = ""


class Layout(types.ModuleType):
    """A kernel array's layout (module docstring): fields in order, each an attribute holding its offset.

    Parameters
    ----------
    prefix : str
        The prefix of the index constants in C (``"C"``: ``C_DT``); also the layout's name.
    fields : iterable of ``(name, size, doc)`` or ``(name, size)``
        The entries in order; a name is upper case and unique, a size a positive int.
    start : int
        Index of the first field (a layout that continues another array, e.g. a block appended to a
        filter's own coefficients); ``LEN`` is then the index after the last field.
    """

    def __init__(self, prefix: str, fields: Iterable[tuple], start: int = 0):
        super().__init__(f"layout {prefix}")
        self.prefix = prefix
        out: list[Field] = []
        offset = int(start)
        for entry in fields:
            name, size, doc = (*entry, "")[:3]
            if not (isinstance(name, str) and name.isidentifier() and name.isupper()) or name == "LEN":
                raise ValueError(f"layout {prefix}: field names are upper-case identifiers other than LEN, "
                                 f"got {name!r}")
            if any(f.name == name for f in out):
                raise ValueError(f"layout {prefix}: field {name!r} declared twice")
            if not (isinstance(size, int) and size > 0):
                raise ValueError(f"layout {prefix}: field {name!r} needs a positive int size, got {size!r}")
            out.append(Field(name, offset, size, doc))
            setattr(self, name, offset)
            offset += size
        self.fields: tuple[Field, ...] = tuple(out)
        self.START = int(start)
        #: the index after the last field: the array's length (for ``start`` 0)
        self.LEN = offset

    def __repr__(self) -> str:
        return f"Layout({self.prefix!r}, {', '.join(f'{f.name}[{f.size}]' for f in self.fields)})"

    def field(self, name: str) -> Field:
        """The field called ``name``; KeyError names the layout's fields."""
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(f"layout {self.prefix}: no field {name!r}; fields: {', '.join(f.name for f in self.fields)}")

    def pack(self, **values) -> np.ndarray:
        """The (``LEN - START``,) float64 array of the fields' ``values`` (a number for a field of length 1, a
        sequence of its length otherwise); every field must be given (ValueError names what is missing)."""
        missing = [f.name for f in self.fields if f.name not in values]
        unknown = sorted(set(values) - {f.name for f in self.fields})
        if missing or unknown:
            raise ValueError(f"layout {self.prefix}: missing {missing}, unknown {unknown}")
        out = np.empty(self.LEN - self.START)
        for f in self.fields:
            v = values[f.name]
            if f.size == 1:
                out[f.offset - self.START] = v
            else:
                a = np.asarray(v, dtype=np.float64)
                if a.shape != (f.size,):
                    raise ValueError(f"layout {self.prefix}: field {f.name} takes {f.size} values, got shape "
                                     f"{a.shape}")
                out[f.offset - self.START:f.offset - self.START + f.size] = a
        return out
