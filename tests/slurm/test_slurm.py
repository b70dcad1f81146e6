"""`kinolab slurm` against a real single-node Slurm cluster on 127.0.0.1.

The cluster runs from a throw-away config (its own state, spool and log folders under a
temporary directory, SLURM_CONF pointing at it, fixed loopback ports, proctrack/linuxproc,
task/none, no accounting, auth/none). Debian's slurmctld, slurmd and slurm-client are
installed when missing. Every client call has a timeout (clients block while the daemons are
down), and every daemon started here is stopped by its PID at the end."""

import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

SOURCE_DIR = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(SOURCE_DIR / "tests" / "support"))
from results import rows  # noqa: E402
BINARY = os.environ.get("KINOLAB_BIN", str(SOURCE_DIR / "build" / "framework" / "kinolab"))
PACKAGES = ["slurmctld", "slurmd", "slurm-client", "munge"]
CONTROLLER_PORT = 16817
NODE_PORT = 16818


def installed(package):
    result = subprocess.run(["dpkg-query", "-W", "-f=${Status}", package],
                            capture_output=True, text=True)
    return "install ok installed" in result.stdout


def ensure_packages():
    missing = [p for p in PACKAGES if not installed(p)]
    if not missing:
        return
    assert os.geteuid() == 0, f"install {' '.join(missing)} (root needed)"
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    subprocess.run(["apt-get", "update", "-qq"], check=True, env=env, timeout=600)
    subprocess.run(["apt-get", "install", "-y", "-qq", "--no-install-recommends", *missing],
                   check=True, env=env, timeout=900)


def port_free(port):
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) != 0


def client(*args, env, timeout=30):
    return subprocess.run(["timeout", str(timeout), *args], capture_output=True, text=True,
                          env=env)


def stop(pid_file, name):
    """Stops a daemon by the PID it wrote."""
    if not pid_file.exists():
        return
    pid = int(pid_file.read_text().split()[0])
    for sig, wait in ((signal.SIGTERM, 10), (signal.SIGKILL, 5)):
        try:
            os.kill(pid, sig)
        except ProcessLookupError:
            return
        for _ in range(wait * 10):
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.1)
    pytest.fail(f"{name} (pid {pid}) did not stop")


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    ensure_packages()
    assert port_free(CONTROLLER_PORT) and port_free(NODE_PORT), \
        f"ports {CONTROLLER_PORT}/{NODE_PORT} are taken (another test cluster running?)"
    root = tmp_path_factory.mktemp("slurm")
    for folder in ("state", "spool", "log"):
        (root / folder).mkdir()
    config = root / "slurm.conf"
    config.write_text(textwrap.dedent(f"""\
        ClusterName=kinolabtest
        SlurmctldHost=localhost(127.0.0.1)
        SlurmctldPort={CONTROLLER_PORT}
        SlurmdPort={NODE_PORT}
        AuthType=auth/none
        CredType=cred/none
        SlurmUser=root
        SlurmdUser=root
        StateSaveLocation={root}/state
        SlurmdSpoolDir={root}/spool
        SlurmctldPidFile={root}/slurmctld.pid
        SlurmdPidFile={root}/slurmd.pid
        SlurmctldLogFile={root}/log/slurmctld.log
        SlurmdLogFile={root}/log/slurmd.log
        ProctrackType=proctrack/linuxproc
        TaskPlugin=task/none
        JobAcctGatherType=jobacct_gather/none
        AccountingStorageType=accounting_storage/none
        SchedulerType=sched/builtin
        SchedulerParameters=sched_interval=1
        SelectType=select/cons_tres
        SelectTypeParameters=CR_CPU
        ReturnToService=2
        MpiDefault=none
        NodeName=kinolab0 NodeHostname={socket.gethostname()} NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
        PartitionName=debug Nodes=kinolab0 Default=YES MaxTime=INFINITE State=UP
        """))
    env = dict(os.environ, SLURM_CONF=str(config))
    try:
        started = client("slurmctld", "-c", "-f", str(config), env=env)
        assert started.returncode == 0, started.stdout + started.stderr
        started = client("slurmd", "-f", str(config), "-N", "kinolab0", env=env)
        assert started.returncode == 0, started.stdout + started.stderr
        for _ in range(60):
            info = client("sinfo", "--noheader", "--format=%T", env=env, timeout=10)
            if info.returncode == 0 and info.stdout.strip() == "idle":
                break
            time.sleep(0.5)
        else:
            pytest.fail("the test cluster never became idle:\n" +
                        (root / "log" / "slurmctld.log").read_text()[-3000:])
        yield env, root
    finally:
        client("scontrol", "shutdown", env=env, timeout=20)
        stop(root / "slurmd.pid", "slurmd")
        stop(root / "slurmctld.pid", "slurmctld")


EXPERIMENT = """kind: planning
name: slurm_test
seed: 9
worlds:
  - id: small
    spec:
SPEC
queries:
  random: {count: 8, min_distance: 3, max_distance: 8}
planners:
  - id: lazy
    type: lazy_mp_astar
    sampler: {type: uniform, params: {samples_per_axis: 3}}
    params: {heuristic_weight: 2}
  - id: tgk
    type: rrtstar_ceres
    params: {refine_iterations: 100}
budget: {time: 5}
"""


def write_experiment(directory):
    spec = (SOURCE_DIR / "tests" / "support" / "small_forest.yaml").read_text()
    experiment = directory / "slurm_test.yaml"
    experiment.write_text(EXPERIMENT.replace("SPEC", textwrap.indent(spec, " " * 6)))
    return experiment


def test_three_shards_on_slurm_merge_to_the_local_unsharded_run(cluster, tmp_path):
    env, _ = cluster
    experiment = write_experiment(tmp_path)
    cache = tmp_path / "cache"
    out = tmp_path / "cluster"

    dry = client(BINARY, "slurm", experiment, "--out", out, "--shards", "3", "--dry-run",
                 env=env)
    assert dry.returncode == 0, dry.stderr
    assert "#SBATCH --array=1-3" in dry.stdout and "nothing submitted" in dry.stdout

    submitted = client(BINARY, "slurm", experiment, "--out", out, "--shards", "3",
                       "--partition", "debug", "--time", "00:10:00", "--cache-dir", cache,
                       env=env, timeout=120)
    assert submitted.returncode == 0, submitted.stdout + submitted.stderr
    assert "submitted: array job" in submitted.stdout
    merged = out / "results.sqlite"
    for _ in range(600):
        queue = client("squeue", "--noheader", env=env, timeout=10)
        if queue.returncode == 0 and not queue.stdout.strip() and merged.exists():
            break
        time.sleep(0.5)
    else:
        logs = "\n".join(p.read_text() for p in (out / "logs").glob("*.out"))
        pytest.fail(f"the merge never finished; queue: {queue.stdout}\n{logs}")
    assert "merged 3 shard(s)" in (out / "logs" / "merge.out").read_text()

    status = client(BINARY, "slurm-status", out, env=env)
    assert status.returncode == 0, status.stderr
    assert status.stdout.count("(complete)") == 3 and "merged database: " + str(merged) in status.stdout

    local = subprocess.run([BINARY, "run", experiment, "--out", tmp_path / "local",
                            "--cache-dir", cache], capture_output=True, text=True, timeout=600)
    assert local.returncode == 0, local.stderr
    expected = rows(tmp_path / "local" / "results.sqlite")
    assert len(expected) == 16
    assert rows(merged) == expected


def test_the_merge_refuses_a_partial_set_of_shards(cluster, tmp_path):
    env, _ = cluster
    experiment = write_experiment(tmp_path)
    out = tmp_path / "partial"
    result = client(BINARY, "run", experiment, "--out", out / "shards" / "1", "--shard", "1/3",
                    env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    merge = client(BINARY, "merge", out / "results.sqlite", out / "shards" / "1" / "results.sqlite",
                   env=env)
    assert merge.returncode == 1 and "1 of 3 shards" in merge.stderr
