"""Dask scheduler addresses are validated at load time and the connection is time-limited
(`parallel.connect_timeout_s`): a wrong address is one error line, never a hang or a traceback."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time

import pytest
import yaml

from tuner.config import ConfigError, config_from_dict

BASE = {"name": "d", "objective": {"kind": "function", "function": "sphere", "dim": 2},
        "optimizer": {"method": "random", "population": 4, "generations": 2}}


@pytest.mark.parametrize("parallel, key, what", [
    ({"backend": "dask", "address": "tcp://host"}, "parallel.address", "a host and a port"),
    ({"backend": "dask", "address": "http://10.0.0.5:8786"}, "parallel.address", "tcp, tls"),
    ({"backend": "dask", "address": "tcp://10.0.0.5:99999"}, "parallel.address", "1-65535"),
    ({"backend": "dask", "address": "tcp://a b:1"}, "parallel.address", "scheduler address"),
    ({"backend": "dask", "address": "tcp://h:1", "connect_timeout_s": 0}, "parallel.connect_timeout_s", "(0, 3600]"),
    ({"backend": "dask", "address": "tcp://h:1", "connect_timeout_s": float("nan")}, "parallel.connect_timeout_s",
     "(0, 3600]"),
    ({"backend": "loky", "connect_timeout_s": 5}, "parallel.connect_timeout_s", "only used with parallel.address"),
])
def test_bad_addresses_and_timeouts_are_refused_at_load(parallel, key, what):
    with pytest.raises(ConfigError) as err:
        config_from_dict({**BASE, "parallel": parallel}, source="job.yaml")
    assert err.value.key == key and what in err.value.message


def test_good_addresses_load_and_the_timeout_stays_out_of_older_configs():
    cfg = config_from_dict({**BASE, "parallel": {"backend": "dask", "address": "tcp://[::1]:8786"}})
    assert cfg.parallel.connect_timeout_s == 30.0 and "connect_timeout_s" not in cfg.raw["parallel"]
    cfg = config_from_dict({**BASE, "parallel": {"backend": "dask", "address": "tls://sched.example.org:8786",
                                                 "connect_timeout_s": 2}})
    assert cfg.parallel.connect_timeout_s == 2.0


@pytest.mark.slow
def test_a_server_that_is_not_a_scheduler_is_one_error_line_within_the_timeout(tmp_path):
    pytest.importorskip("distributed", reason="needs the cluster extra")
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    port = srv.getsockname()[1]

    def silent():  # accepts and says nothing, as a wrong service would
        conns = []
        while True:
            try:
                conns.append(srv.accept()[0])
            except OSError:
                return

    threading.Thread(target=silent, daemon=True).start()
    job = tmp_path / "job.yaml"
    job.write_text(yaml.safe_dump({**BASE, "output": str(tmp_path / "runs"),
                                   "parallel": {"backend": "dask", "address": f"tcp://127.0.0.1:{port}",
                                                "connect_timeout_s": 2}}))
    t0 = time.time()
    out = subprocess.run([sys.executable, "-m", "tuner", "run", str(job)], capture_output=True, text=True, timeout=120)
    srv.close()
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    errors = [ln for ln in out.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "parallel.address" in errors[0], out.stderr
    assert time.time() - t0 < 40
