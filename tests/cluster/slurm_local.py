"""A real one-node SLURM cluster on this machine, for the cluster tests.

`LocalSlurm` installs Debian's ``slurm-wlm slurmdbd mariadb-server munge`` with apt-get
when a daemon is missing, writes ``slurm.conf``, ``slurmdbd.conf`` and ``cgroup.conf`` for
localhost into a scratch directory, starts munge, mariadb, slurmdbd, slurmctld and slurmd
in the foreground (no systemd: each is a child process in its own session, on ports picked
free on 127.0.0.1, with its state, sockets and logs in that directory), creates the
accounting database, registers the cluster with ``sacctmgr`` and waits until ``sinfo``
shows the node idle. `LocalSlurm.stop` cancels every job and ends exactly the processes
it started, by process id, then removes the cgroups that SLURM created. Outside the
scratch directory it writes only those cgroups and a symlink ``/etc/slurm/slurm.conf``
(removed at the end; a machine that has one already is refused), because srun inside a job
finds its configuration only there (see `DEFAULT_CONF`); the packages stay installed.
Clients reach the cluster through ``SLURM_CONF`` in `LocalSlurm.env`.

Command line (for a manual session; Ctrl-C stops the cluster)::

    python tests/cluster/slurm_local.py serve /tmp/slurm   # prints the export line
    python tests/cluster/slurm_local.py stop /tmp/slurm    # after a serve that was killed
"""

from __future__ import annotations

import json
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

#: Debian packages of the cluster (bookworm: SLURM 22.05, MariaDB 10.11).
PACKAGES = ("slurm-wlm", "slurmdbd", "mariadb-server", "munge")
#: Programs that must be on PATH after the install.
PROGRAMS = ("munged", "mariadbd", "mariadb-install-db", "mariadb", "slurmdbd", "slurmctld",
            "slurmd", "sacctmgr", "sinfo", "sbatch", "sacct", "scancel", "squeue")
CLUSTER = "gbpipe"
#: Where srun looks for the configuration when ``SLURM_CONF`` is unset: Snakemake's
#: jobstep executor unsets every ``SLURM_*`` variable before it calls srun inside a job.
DEFAULT_CONF = Path("/etc/slurm/slurm.conf")
#: Seconds any start-up wait gives a daemon to answer: each wait ends as soon as the
#: daemon answers, so only a hang reaches this, never a loaded machine.
HANG_S = 900.0
#: Memory controller of a cgroup v1 hierarchy (what SLURM 22.05 uses without systemd).
CGROUP_V1_MEMORY = Path("/sys/fs/cgroup/memory")


class SlurmUnavailable(RuntimeError):
    """The cluster cannot be had here (no root, no apt-get, or the install failed)."""


def _sbin_path() -> str:
    # the daemons live in /usr/sbin, which a non-login root shell may not have on PATH
    return os.pathsep.join([os.environ.get("PATH", ""), "/usr/sbin", "/sbin"])


def missing_programs() -> list[str]:
    """Programs of `PROGRAMS` not found on PATH (+ /usr/sbin)."""
    return [p for p in PROGRAMS if shutil.which(p, path=_sbin_path()) is None]


def install() -> float:
    """Install `PACKAGES` with apt-get when a program is missing; return the seconds taken.

    Raises `SlurmUnavailable` with the reason (not root, no apt-get, or apt's error).
    Recommends are skipped (28 packages instead of 77); services are not started by the
    packages where a ``policy-rc.d`` forbids it, and are never used if they are.
    """
    start = time.monotonic()
    if not missing_programs():
        return 0.0
    if os.geteuid() != 0:
        raise SlurmUnavailable(f"not root: cannot apt-get install {' '.join(PACKAGES)}")
    if shutil.which("apt-get") is None:
        raise SlurmUnavailable("no apt-get on this machine: cannot install SLURM")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    for cmd in (["apt-get", "update", "-qq"],
                ["apt-get", "install", "-y", "-q", "--no-install-recommends", *PACKAGES]):
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if proc.returncode != 0:
            raise SlurmUnavailable(f"`{' '.join(cmd)}` failed ({proc.returncode}): "
                                   f"{(proc.stderr or proc.stdout)[-1500:]}")
    if missing := missing_programs():
        raise SlurmUnavailable(f"installed {PACKAGES} but still missing {missing}")
    return time.monotonic() - start


def cgroups_usable() -> bool:
    """Whether a cgroup v1 memory hierarchy is mounted and writable (a child can be made).

    SLURM 22.05's cgroup/v2 plugin needs systemd (a scope per slurmd), which a container
    lacks; v1 works without it. Without cgroups, memory is enforced by sampling
    (jobacct_gather/linux with OverMemoryKill).
    """
    probe = CGROUP_V1_MEMORY / f"gbpipe_probe_{os.getpid()}"
    try:
        probe.mkdir()
        ok = (probe / "memory.limit_in_bytes").exists()
        probe.rmdir()
        return ok
    except OSError:
        return False


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def node_hardware() -> str:
    """This machine's CPUs and memory as a slurm.conf node line tail (``slurmd -C``)."""
    out = subprocess.run([shutil.which("slurmd", path=_sbin_path()), "-C"],
                         capture_output=True, text=True, check=True).stdout
    line = next(x for x in out.splitlines() if x.startswith("NodeName="))
    return " ".join(f for f in line.split()[1:] if not f.startswith("UpTime"))


class LocalSlurm:
    """One-node SLURM cluster whose state lives in ``root``; see the module docstring."""

    def __init__(self, root: Path):
        self.root = Path(root).resolve()
        self.host = socket.gethostname().split(".")[0]
        self.cgroups = cgroups_usable()
        self.timings: dict[str, float] = {}
        self._procs: list[tuple[str, int]] = []
        self._cgroups_before = self._slurm_cgroups()

    def client_env(self, base: dict[str, str] | None = None) -> dict[str, str]:
        """``base`` (default: this process's environment) for SLURM clients (sbatch, sacct,
        Snakemake's executor) of this cluster."""
        return dict(os.environ if base is None else base,
                    SLURM_CONF=str(self.root / "slurm.conf"), PATH=_sbin_path())

    @property
    def env(self) -> dict[str, str]:
        """This process's environment for SLURM clients of this cluster."""
        return self.client_env()

    def run(self, *cmd: str, check: bool = True) -> subprocess.CompletedProcess:
        """Run a SLURM client command against this cluster."""
        proc = subprocess.run(cmd, env=self.env, capture_output=True, text=True)
        if check and proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)}: {proc.stderr.strip()}")
        return proc

    # ------------------------------------------------------------------ start-up
    def start(self, timeout: float = HANG_S) -> dict[str, float]:
        """Start every daemon, register the cluster, wait for the idle node.

        Each wait is on the daemon's answer; ``timeout`` [s] only ends a hang (a loaded
        machine takes longer, never fails).

        Returns the seconds of each step. On any failure, stops what was started.
        """
        self.root.mkdir(parents=True, exist_ok=True)
        for d in ("state", "spool", "mysql", "log"):
            (self.root / d).mkdir(exist_ok=True)
        try:
            self._step("config", self._write_config)
            self._link_default_conf()
            self._step("munge", self._start_munge)
            self._step("mariadb", self._start_mariadb)
            self._step("slurmdbd", lambda: self._start_daemon("slurmdbd", "-D"))
            self._step("slurmdbd_ready", lambda: self._wait(
                lambda: self.run("sacctmgr", "-n", "list", "cluster", check=False)
                .returncode == 0, timeout, "slurmdbd answering sacctmgr"))
            self._step("sacctmgr", lambda: self.run("sacctmgr", "-i", "add", "cluster",
                                                    CLUSTER))
            self._step("slurmctld", lambda: self._start_daemon("slurmctld", "-D", "-i"))
            self._step("slurmd", lambda: self._start_daemon("slurmd", "-D", "-N", self.host))
            self._step("node_idle", lambda: self._wait(self._node_idle, timeout,
                                                       "the node idle in sinfo"))
        except BaseException:
            self.stop()
            raise
        self._save_pids()
        return self.timings

    def _step(self, name: str, fn) -> None:
        start = time.monotonic()
        fn()
        self.timings[name] = time.monotonic() - start

    def _write_config(self) -> None:
        r = self.root
        self.ports = {k: _free_port() for k in ("mysql", "dbd", "ctld", "slurmd")}
        self.db_password = secrets.token_hex(8)
        auth = f"AuthType=auth/munge\nAuthInfo=socket={r / 'munge.sock'}\n"
        if self.cgroups:
            track = ("ProctrackType=proctrack/cgroup\nTaskPlugin=task/cgroup\n"
                     "JobAcctGatherType=jobacct_gather/cgroup\n")
        else:
            track = ("ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n"
                     "JobAcctGatherType=jobacct_gather/linux\n"
                     "JobAcctGatherParams=OverMemoryKill\n")
        (r / "slurm.conf").write_text(
            f"ClusterName={CLUSTER}\nSlurmctldHost={self.host}(127.0.0.1)\n"
            f"SlurmctldPort={self.ports['ctld']}\nSlurmdPort={self.ports['slurmd']}\n"
            "SlurmUser=root\nSlurmdUser=root\n" + auth + "CredType=cred/munge\n"
            f"StateSaveLocation={r / 'state'}\nSlurmdSpoolDir={r / 'spool'}\n"
            f"SlurmctldPidFile={r / 'slurmctld.pid'}\nSlurmdPidFile={r / 'slurmd.pid'}\n"
            f"SlurmctldLogFile={r / 'log/slurmctld.log'}\n"
            f"SlurmdLogFile={r / 'log/slurmd.log'}\n"
            "SelectType=select/cons_tres\nSelectTypeParameters=CR_Core_Memory\n"
            "DefMemPerCPU=1000\n" + track + "JobAcctGatherFrequency=task=1\n"
            "AccountingStorageType=accounting_storage/slurmdbd\n"
            # sacct shows the comment, where Snakemake's executor names each job's rule
            "AccountingStoreFlags=job_comment\n"
            # the munge socket of connections to slurmdbd (AuthInfo covers the others)
            f"AccountingStoragePass={r / 'munge.sock'}\n"
            f"AccountingStorageHost=localhost\nAccountingStoragePort={self.ports['dbd']}\n"
            "JobCompType=jobcomp/none\nMpiDefault=none\nSchedulerType=sched/backfill\n"
            "ReturnToService=2\nKillWait=5\nMinJobAge=300\nInactiveLimit=0\n"
            "SlurmctldDebug=info\nSlurmdDebug=info\n"
            f"NodeName={self.host} NodeAddr=127.0.0.1 {node_hardware()} State=UNKNOWN\n"
            "PartitionName=main Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n")
        (r / "cgroup.conf").write_text(
            "CgroupPlugin=cgroup/v1\nCgroupMountpoint=/sys/fs/cgroup\n"
            "ConstrainRAMSpace=yes\nConstrainSwapSpace=yes\nAllowedSwapSpace=0\n")
        dbd = r / "slurmdbd.conf"
        dbd.write_text(
            f"DbdHost=localhost\nDbdPort={self.ports['dbd']}\nSlurmUser=root\n" + auth +
            f"PidFile={r / 'slurmdbd.pid'}\nLogFile={r / 'log/slurmdbd.log'}\n"
            "StorageType=accounting_storage/mysql\nStorageHost=127.0.0.1\n"
            f"StoragePort={self.ports['mysql']}\nStorageUser=slurm\n"
            f"StoragePass={self.db_password}\nStorageLoc=slurm_acct_db\n")
        dbd.chmod(0o600)  # slurmdbd refuses a readable file (it holds the password)

    def _link_default_conf(self) -> None:
        if _stale_test_link(DEFAULT_CONF):
            # a test cluster killed before its stop (SIGKILL of pytest): none of its daemons
            # runs any more, so its link is removed, never a machine's own configuration
            DEFAULT_CONF.unlink()
        if DEFAULT_CONF.exists() or DEFAULT_CONF.is_symlink():
            raise RuntimeError(f"{DEFAULT_CONF} exists: this machine has a SLURM of its own; "
                               "the test cluster will not replace its configuration")
        DEFAULT_CONF.parent.mkdir(parents=True, exist_ok=True)
        DEFAULT_CONF.symlink_to(self.root / "slurm.conf")

    def _popen(self, name: str, *cmd: str) -> None:
        log = open(self.root / "log" / f"{name}.out", "w")
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=self.env,
                                start_new_session=True, stdin=subprocess.DEVNULL)
        log.close()
        self._procs.append((name, proc.pid))
        self._save_pids()

    def _start_daemon(self, name: str, *args: str) -> None:
        self._popen(name, shutil.which(name, path=_sbin_path()), *args)

    def _start_munge(self) -> None:
        key = self.root / "munge.key"
        key.write_bytes(secrets.token_bytes(1024))
        key.chmod(0o400)
        r = self.root
        self._popen("munged", shutil.which("munged", path=_sbin_path()), "-F", "--force",
                    f"--key-file={key}", f"--socket={r / 'munge.sock'}",
                    f"--pid-file={r / 'munged.pid'}", f"--seed-file={r / 'munge.seed'}",
                    f"--log-file={r / 'log/munged.log'}")
        self._wait(lambda: (r / "munge.sock").exists(), HANG_S, "munged's socket")

    def _mysql(self, sql: str) -> None:
        subprocess.run(["mariadb", "--no-defaults", f"--socket={self.root / 'mysql.sock'}",
                        "-u", "root", "-e", sql], check=True, capture_output=True)

    def _start_mariadb(self) -> None:
        r = self.root
        subprocess.run(["mariadb-install-db", "--no-defaults", f"--datadir={r / 'mysql'}",
                        "--user=root", "--skip-test-db"], check=True, capture_output=True)
        # small buffers: the accounting database holds a few hundred rows
        self._popen("mariadbd", shutil.which("mariadbd", path=_sbin_path()), "--no-defaults",
                    f"--datadir={r / 'mysql'}", f"--socket={r / 'mysql.sock'}",
                    f"--port={self.ports['mysql']}", "--bind-address=127.0.0.1",
                    "--user=root", f"--pid-file={r / 'mariadbd.pid'}",
                    f"--log-error={r / 'log/mariadbd.log'}", "--innodb-buffer-pool-size=32M",
                    "--innodb-log-file-size=16M", "--skip-log-bin")
        self._wait(lambda: subprocess.run(
            ["mariadb-admin", "--no-defaults", f"--socket={r / 'mysql.sock'}", "ping"],
            capture_output=True).returncode == 0, HANG_S, "mariadbd answering ping")
        self._mysql("CREATE DATABASE slurm_acct_db; "
                    f"CREATE USER 'slurm'@'127.0.0.1' IDENTIFIED BY '{self.db_password}'; "
                    "GRANT ALL ON slurm_acct_db.* TO 'slurm'@'127.0.0.1';")

    def _node_idle(self) -> bool:
        out = self.run("sinfo", "-h", "-N", "-o", "%N %t", check=False).stdout.split()
        return out == [self.host, "idle"]

    def _wait(self, ready, timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not ready():
            dead = [n for n, pid in self._procs if not _alive(pid)]
            if dead or time.monotonic() > deadline:
                logs = "\n".join(f"--- {p.name}\n{p.read_text()[-1500:]}"
                                 for p in sorted((self.root / "log").glob("*")))
                raise RuntimeError(f"waiting for {what}: "
                                   f"{f'{dead} exited' if dead else 'timed out'}\n{logs}")
            time.sleep(0.2)

    # ------------------------------------------------------------------ stop
    def stop(self) -> None:
        """Cancel every job, end the started daemons (newest first) by pid, drop cgroups."""
        if any(n == "slurmctld" for n, _ in self._procs):
            self.run("scancel", "--user", "root", check=False)
            deadline = time.monotonic() + 30
            while (time.monotonic() < deadline
                   and self.run("squeue", "-h", check=False).stdout.strip()):
                time.sleep(0.5)
        for _, pid in reversed(self._procs):
            _terminate(pid)
        self._procs = []
        self._save_pids()
        if DEFAULT_CONF.is_symlink() and DEFAULT_CONF.resolve() == self.root / "slurm.conf":
            DEFAULT_CONF.unlink()
        for cg in sorted(self._slurm_cgroups() - self._cgroups_before,
                         key=lambda p: -len(p.parts)):
            for d in sorted(cg.rglob("*"), key=lambda p: -len(p.parts)) + [cg]:
                if d.is_dir():
                    try:
                        d.rmdir()
                    except OSError:
                        pass

    @staticmethod
    def _slurm_cgroups() -> set[Path]:
        return {p for p in Path("/sys/fs/cgroup").glob("*/slurm*") if p.is_dir()}

    def _save_pids(self) -> None:
        if self.root.exists():
            (self.root / "pids.json").write_text(json.dumps(self._procs))

    @classmethod
    def attach(cls, root: Path) -> LocalSlurm:
        """The cluster started in ``root`` by another process (for ``stop`` on the CLI)."""
        cluster = cls(root)
        cluster._procs = [tuple(x) for x in json.loads((Path(root) / "pids.json").read_text())]
        cluster._cgroups_before = set()
        return cluster


def _stale_test_link(conf: Path) -> bool:
    """``conf`` is a symlink to a test cluster's ``slurm.conf`` whose daemons are all gone
    (or whose folder pytest has since pruned: a dangling link into its temporary root)."""
    if not conf.is_symlink():
        return False
    target = Path(os.readlink(conf))
    if not target.parent.exists():
        return any(part.startswith("pytest-of-") for part in target.parts)
    pids = target.parent / "pids.json"
    if not pids.is_file():
        return False
    procs = json.loads(pids.read_text())
    return not any(_alive(int(x)) for proc in procs for x in proc if isinstance(x, int))


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie child counts as gone
    stat = Path(f"/proc/{pid}/stat")
    return stat.exists() and re.sub(r"^.*\) ", "", stat.read_text())[:1] != "Z"


def _terminate(pid: int, grace: float = 20.0) -> None:
    """SIGTERM ``pid``, SIGKILL it after ``grace`` seconds; reap it if it is our child."""
    if not _alive(pid):
        return
    os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + grace
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    if _alive(pid):
        os.kill(pid, signal.SIGKILL)
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:
        pass


def main(argv: list[str]) -> int:
    """``serve DIR`` or ``stop DIR`` (see the module docstring)."""
    if len(argv) != 2 or argv[0] not in ("serve", "stop"):
        print(__doc__, file=sys.stderr)
        return 2
    root = Path(argv[1]).resolve()
    if argv[0] == "stop":
        LocalSlurm.attach(root).stop()
        return 0
    print(f"install: {install():.1f} s", file=sys.stderr)
    cluster = LocalSlurm(root)
    for step, seconds in cluster.start().items():
        print(f"{step}: {seconds:.1f} s", file=sys.stderr)
    print(f"export SLURM_CONF={root / 'slurm.conf'}", flush=True)
    # serve until interrupted: the daemons are our children, so stopping them reaps them
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    signal.signal(signal.SIGINT, signal.default_int_handler)  # also when started with &
    try:
        signal.pause()
    except KeyboardInterrupt:
        pass
    finally:
        cluster.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
