"""A small rastrigin job for the run and run-directory tests."""

from tuner.config import config_from_dict


def rastrigin_job(tmp_path, dim: int, population: int, generations: int, **over):
    """The config of a serial PSO run on ``dim``-D Rastrigin; ``over`` updates top-level sections."""
    raw = {"name": "t", "seed": 3,
           "objective": {"kind": "function", "function": "rastrigin", "dim": dim},
           "optimizer": {"method": "pso", "population": population, "generations": generations},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    for k, v in over.items():
        raw[k] = {**raw.get(k, {}), **v} if isinstance(v, dict) else v
    return config_from_dict(raw, source=str(tmp_path / "job.yaml"), base_dir=tmp_path)
