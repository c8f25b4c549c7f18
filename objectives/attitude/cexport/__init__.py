"""C99 source of the attitude filters firmware runs, with a tuned configuration baked in.

``render_c_filter(flt, ...)`` turns a validated filter whose class declares a C port (``c_port``, a
:class:`~objectives.attitude.cexport.port.CPort` in the filter's unit, beside its kernel) into a header and a
source file. The port is a line-by-line port of the unit's numba kernel (same operations in the same order,
the same start orientation, the robust blocks in the kernel's order), so that it computes what the tuning
scored; ``tests/attitude/test_cexport*.py`` compile every port of the registry and compare it with its kernel
sample by sample. This package is the machinery only: the renderer (``render.py``), the port contract
(``port.py``), the build (``build.py``), the objective's hooks (``hooks.py``) and the shared C parts
(``templates/``); it never names a filter.

Each filter is one struct and a streaming API without heap or global state::

    PREFIX_filter f;
    PREFIX_init(&f, &PREFIX_tuned);
    PREFIX_update(&f, gyr, acc, mag, dt_s);   /* per sample: rad/s, m/s^2, any unit (NULL: none), s */
    PREFIX_quaternion(&f, q);                 /* sensor-to-earth (w, x, y, z), ENU */

Only ``sqrt``, ``exp``, ``asin`` and ``atan2`` of libm are called (sine and cosine, for exact quaternion steps
and Euler angles, are a series, ``trig.c``, within 1 ulp of libm's). Compiled with ``-DPREFIX_LIBM_TRIG`` the port
calls libm's ``sin`` and ``cos`` instead, as the numba kernel does: it then runs the kernel's operations (a port
whose output needs no frame change equals its kernel bit for bit), at the price of libm's slower sine and cosine.
``precision="float"`` writes every literal and call in single precision for MCUs without a double FPU.

The ports and the shared parts (``templates/*.c``, ``*.h``) name public identifiers ``PFX_`` and use ``real``,
``SQRT``, ``EXP``, ``ASIN``, ``ATAN2``, ``fabs``; :func:`render_c_filter` replaces them. A source is the parts
``common.c``; the shared parts the port lists, of ``robust.c`` (the robust blocks: their init and rate
coefficients too), ``bias_prologue.c`` (the prologue of the quaternion-and-bias filters), ``trig.c`` (sine and
cosine), ``angle.c`` (angle wrapping); the C enums of the kernel's layouts and the port's own source; ``run.c``,
in that order, so a piece two ports need is written once, in the first part both get.
"""

from __future__ import annotations

from objectives.attitude.cexport.port import CField, CMember, CPort, RenderContext
from objectives.attitude.cexport.render import c_filter_names, c_identifier, c_port, render_c_filter

__all__ = ["render_c_filter", "c_filter_names", "c_port", "CField", "CMember", "CPort", "RenderContext",
           "c_identifier"]
