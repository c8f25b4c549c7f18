"""Step responses for the interactive report (objectives.control.plants.wmp.report.traces_doc): the tuned and the
initial closed loop against the references, as the objective's own traces, in the engine's format."""

import json

import numpy as np

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.wmp.report import traces_doc
from tuner.interactive import read_traces


def test_step_responses_hold_reference_initial_and_tuned(tmp_path):
    obj = ClosedLoopObjective(controller="lqr", duration_s=3.0)
    init = dict(obj.defaults)
    tuned = {**init, "q_nu": float(init["q_nu"]) * 10}
    doc = traces_doc(obj.loop, init, tuned)
    text = json.dumps(doc, allow_nan=False)  # plain JSON: NaN would break the page's JSON.parse
    (tmp_path / "traces.json").write_text(text)
    back = read_traces(tmp_path)
    assert back is not None and len(back["items"]) == 1 and back["replaces"] == ["response.png"]
    item = back["items"][0]
    panels = {p["title"]: p for p in item["panels"]}
    assert panels["speed"]["unit"] == "m/s" and panels["yaw rate"]["unit"] == "deg/s"
    assert [s["name"] for s in panels["speed"]["series"]] == ["reference", "initial", "tuned"]
    assert [s["name"] for s in panels["IB angle theta3"]["series"]] == ["initial", "tuned"]  # no reference
    ref = obj.traces(tuned)["speed (m/s)"]
    step = int(np.ceil(len(ref["t"]) / 2000))
    np.testing.assert_allclose(item["x"], np.round(ref["t"][::step], 5))
    np.testing.assert_allclose(panels["speed"]["series"][2]["y"], np.round(ref["y"][::step], 5))
    assert panels["speed"]["series"][1]["y"] != panels["speed"]["series"][2]["y"]  # the two gains differ
