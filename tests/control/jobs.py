"""A PI tuning of a closed loop as a config file, for the tests that run one through ``tuner run``."""

from __future__ import annotations

from pathlib import Path

import yaml


def pi_job(tmp_path: Path, name: str, objective: dict, K: tuple[float, float], Ti_s: tuple[float, float],
           population: int, generations: int, seed: int = 1) -> tuple[Path, dict]:
    """``<name>.yaml`` in ``tmp_path`` and its dict: a serial PSO (``population`` x ``generations``) of
    ``objective``'s ``K`` and ``Ti_s`` within the log-scaled bounds ``K`` and ``Ti_s`` (``(low, high)``), its
    runs written below ``tmp_path / "runs"``."""
    job = {"name": name, "seed": seed, "objective": objective,
           "parameters": {"K": {"low": K[0], "high": K[1], "scale": "log"},
                          "Ti_s": {"low": Ti_s[0], "high": Ti_s[1], "scale": "log"}},
           "optimizer": {"method": "pso", "population": population, "generations": generations},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(job))
    return path, job
