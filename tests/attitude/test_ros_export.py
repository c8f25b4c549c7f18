"""``tuner export RUN --format ros2-params | ros1-params``: the parameter file of the ROS node that runs the tuned
filter, checked against a table of the nodes' documented parameters (names, types, defaults) written here from
the nodes' parameter documentation (imu_tools: imu_filter_madgwick, imu_complementary_filter)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from objectives.attitude.filters.imu_tools_madgwick import ImuToolsMadgwick
from objectives.attitude.filters.valenti import Valenti
from objectives.attitude.ros_params import ros_values, ros_yaml
from tests.conftest import run_tuner

#: the nodes' documented parameters: name -> (type, default)
DOCUMENTED = {
    "imu_filter_madgwick": {
        "gain": (float, 0.1), "zeta": (float, 0.0), "mag_bias_x": (float, 0.0), "mag_bias_y": (float, 0.0),
        "mag_bias_z": (float, 0.0), "orientation_stddev": (float, 0.0), "world_frame": (str, "enu"),
        "use_mag": (bool, True), "fixed_frame": (str, "odom"), "publish_tf": (bool, True),
        "reverse_tf": (bool, False), "constant_dt": (float, 0.0), "publish_debug_topics": (bool, False),
        "stateless": (bool, False), "remove_gravity_vector": (bool, False)},
    "imu_complementary_filter": {
        "gain_acc": (float, 0.01), "gain_mag": (float, 0.01), "bias_alpha": (float, 0.01),
        "do_bias_estimation": (bool, True), "do_adaptive_gain": (bool, True), "use_mag": (bool, False),
        "fixed_frame": (str, "odom"), "publish_tf": (bool, False), "reverse_tf": (bool, False),
        "constant_dt": (float, 0.0), "publish_debug_topics": (bool, False), "orientation_stddev": (float, 0.0)},
}
CLASSES = {"imu_filter_madgwick": ImuToolsMadgwick, "imu_complementary_filter": Valenti}


@pytest.mark.parametrize("node", list(DOCUMENTED))
def test_the_parameter_map_is_the_nodes_documented_table(node):
    cls = CLASSES[node]
    table = DOCUMENTED[node]
    assert cls.ros.node == node
    assert {k: v for k, v in cls.ros.documented.items()} == {k: d for k, (_, d) in table.items()}
    # the filter's defaults are the node's defaults, each written as the node's name and type
    vals = ros_values(cls.ros, cls().values)
    for name, v in vals.items():
        typ, default = table[name]
        assert type(v) is typ and v == default, (name, v)
    # every parameter the filter deploys is one the node documents
    assert set(vals) <= set(table)


@pytest.mark.parametrize("version", [1, 2])
def test_yaml_loads_into_the_nodes_names_and_types(version):
    flt = ImuToolsMadgwick(gain=0.0423, zeta=0.004, world_frame="ned", mag_bias_x=12.5, use_mag=True)
    doc = yaml.safe_load(ros_yaml(flt.ros, flt.values, version, ["run: x", "fitness: 1.0"]))
    params = doc["imu_filter_madgwick"]["ros__parameters"] if version == 2 else doc
    assert params == {"gain": 0.0423, "zeta": 0.004, "mag_bias_x": 12.5e-6, "mag_bias_y": 0.0, "mag_bias_z": 0.0,
                      "world_frame": "ned", "use_mag": True}
    for k, v in params.items():
        assert type(v) is DOCUMENTED["imu_filter_madgwick"][k][0], k


def test_values_the_node_cannot_express_are_named():
    with pytest.raises(ValueError, match=r"imu_complementary_filter cannot express: init = 'truth' \(the node "
                                         r"starts from its first sample: init auto\)"):
        ros_values(Valenti.ros, Valenti(init="truth").values)
    with pytest.raises(ValueError, match=r"cannot express: .*extra = 1 \(the node has no such parameter\)"):
        ros_values(Valenti.ros, {**Valenti().values, "extra": 1})


def _tune(tmp_path: Path, flt: str, fixed: dict) -> Path:
    job = {"name": f"ros-{flt}", "seed": 1,
           "objective": {"kind": "filter", "filter": flt, "fixed": fixed, "warmup_s": 1.0,
                         "data": [{"synthetic": {"generator": "bench6dof", "duration_s": 8, "rate_hz": 100,
                                                 "seed": 2, "frame": "ENU"}}],
                         "report": {"traces": False}},
           "optimizer": {"method": "pso", "population": 4, "generations": 2},
           "parallel": {"backend": "serial", "n_jobs": 1}}
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(job))
    r = run_tuner("run", str(tmp_path / "job.yaml"), "--run-dir", str(tmp_path / "run"), "--no-report", "-q",
                  cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    return tmp_path / "run"


@pytest.mark.slow
def test_export_of_a_run_writes_the_nodes_parameter_file(tmp_path):
    run = _tune(tmp_path, "imu_tools_madgwick", {"world_frame": "ned", "zeta": 0.01})
    best = yaml.safe_load((run / "best.yaml").read_text())
    r2 = run_tuner("export", str(run), "--format", "ros2-params")
    assert r2.returncode == 0, r2.stderr
    assert r2.stdout.startswith("# imu_filter_madgwick parameters") and "# fitness: " in r2.stdout
    p2 = yaml.safe_load(r2.stdout)["imu_filter_madgwick"]["ros__parameters"]
    assert p2["gain"] == best["deployment"]["values"]["gain"] and p2["world_frame"] == "ned" and p2["zeta"] == 0.01
    assert set(p2) == {"gain", "zeta", "mag_bias_x", "mag_bias_y", "mag_bias_z", "world_frame", "use_mag"}
    r1 = run_tuner("export", str(run), "--format", "ros1-params", "-o", str(tmp_path / "p.yaml"))
    assert r1.returncode == 0, r1.stderr
    assert yaml.safe_load((tmp_path / "p.yaml").read_text()) == p2
    bad = run_tuner("export", str(run), "--format", "ros3-params")
    assert bad.returncode == 2 and "ros2-params" in bad.stderr and "yaml" in bad.stderr


@pytest.mark.slow
def test_export_names_a_value_the_node_cannot_run(tmp_path):
    # a start from the truth only served scoring: the deployed filter starts from its first sample, as the node
    truth = _tune(tmp_path / "t", "valenti", {"init": "truth", "use_mag": True}) if (tmp_path / "t").mkdir() is None \
        else None
    r = run_tuner("export", str(truth), "--format", "ros2-params")
    assert r.returncode == 0, r.stderr
    assert yaml.safe_load(r.stdout)["imu_complementary_filter"]["ros__parameters"]["use_mag"] is True
    # BROAD's start is part of the deployed filter, and the node has no such start
    run = _tune(tmp_path, "valenti", {"init": "broad", "use_mag": True})
    r = run_tuner("export", str(run), "--format", "ros2-params")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "best.yaml: deployment: imu_complementary_filter cannot express: init = 'broad'" in r.stderr
    other = _tune(tmp_path / "m", "madgwick", {}) if (tmp_path / "m").mkdir() is None else None
    r = run_tuner("export", str(other), "--format", "ros2-params")
    assert r.returncode == 2 and "allowed: yaml" in r.stderr and "ros2-params" not in r.stderr.split("allowed:")[1]
