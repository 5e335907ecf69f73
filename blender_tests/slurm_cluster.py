# A real single-node Slurm in a temporary folder, for the Slurm test and measurement (root only).
#
#   cluster = SlurmCluster(); cluster.start()      # munged, slurmctld, slurmd: node = this host
#   subprocess.run(["sbatch", ...], env=cluster.env)
#   leftovers = cluster.stop()                     # [] when nothing of the cluster was left running
#
# Everything lives in the folder: its own slurm.conf (free ports, no accounting, no cgroups),
# munge key and socket, state, spool and logs; nothing in /etc is read or written. The
# daemons run in the foreground as children of this process, so they are stopped by PID.
# Every process of the cluster (daemons, slurmstepd, job scripts and what they start)
# carries ARAP_SLURM_CLUSTER=<folder> in its environment: stop() looks for such processes
# after stopping the daemons, kills them and returns what it found.
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time

DAEMONS = ("munged", "slurmctld", "slurmd")
CLIENTS = ("sbatch", "squeue", "scancel", "scontrol", "sinfo")
SBIN = os.pathsep.join(("/usr/sbin", "/sbin"))


def _which(name):
    return shutil.which(name) or shutil.which(name, path=SBIN)


def unavailable():
    """Why a single-node Slurm cannot be started here, or None."""
    if os.geteuid() != 0:
        return "needs root (it starts munged, slurmctld and slurmd)"
    missing = [c for c in DAEMONS + CLIENTS if _which(c) is None]
    if missing:
        return "Slurm is not installed (%s not found): apt-get install slurm-wlm munge" % ", ".join(missing)
    return None


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _node_line():
    """This host as slurmd sees it (`slurmd -C`), reachable on 127.0.0.1; RealMemory left out
    so that a little less free memory at registration does not drain the node."""
    out = subprocess.run([_which("slurmd"), "-C"], capture_output=True, text=True, check=True).stdout
    fields = [f for f in out.splitlines()[0].split() if not f.startswith("RealMemory=")]
    return " ".join(fields + ["NodeAddr=127.0.0.1", "State=UNKNOWN"]), fields[0].split("=", 1)[1]


class SlurmCluster:
    def __init__(self):
        self.dir = None
        self.procs = []     # [(name, Popen)] in start order
        self.env = None

    def path(self, *parts):
        return os.path.join(self.dir, *parts)

    def start(self, timeout=60.0):
        self.dir = tempfile.mkdtemp(prefix="arap-slurm-")
        os.chmod(self.dir, 0o755)       # munged wants the folders above its socket searchable by all
        for sub in ("munge", "state", "spool", "log"):
            os.makedirs(self.path(sub))
        key = self.path("munge", "munge.key")
        with open(os.open(key, os.O_WRONLY | os.O_CREAT, 0o400), "wb") as f:
            f.write(os.urandom(1024))
        node, name = _node_line()
        conf = self.path("slurm.conf")
        with open(conf, "w") as f:
            f.write(CONF.format(dir=self.dir, host=socket.gethostname().split(".")[0], node=node, name=name,
                                ctld_port=_free_port(), slurmd_port=_free_port()))
        self.env = dict(os.environ, SLURM_CONF=conf, ARAP_SLURM_CLUSTER=self.dir)
        try:
            self._spawn("munged", [_which("munged"), "--foreground", "--socket=" + self.path("munge", "socket"),
                                   "--key-file=" + key, "--pid-file=" + self.path("munge", "munged.pid"),
                                   "--log-file=" + self.path("log", "munged.log"),
                                   "--seed-file=" + self.path("munge", "seed")])
            self._wait(lambda: os.path.exists(self.path("munge", "socket")), timeout, "munged's socket")
            self._spawn("slurmctld", [_which("slurmctld"), "-D", "-i", "-f", conf])
            self._spawn("slurmd", [_which("slurmd"), "-D", "-f", conf, "-N", name])
            self._wait(self._idle, timeout, "the node to be idle")
        except BaseException:
            self.stop()
            raise
        return self

    def _spawn(self, name, cmd):
        log = open(self.path("log", name + ".out"), "w")
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                                env=self.env, start_new_session=True)
        log.close()
        self.procs.append((name, proc))

    def _wait(self, ready, timeout, what):
        deadline = time.monotonic() + timeout
        while not ready():
            for name, proc in self.procs:
                if proc.poll() is not None:
                    raise RuntimeError("%s exited with %s while waiting for %s:\n%s"
                                       % (name, proc.returncode, what, self.log_tail(name)))
            if time.monotonic() > deadline:
                raise RuntimeError("Slurm: no %s after %g s:\n%s" % (what, timeout, self.log_tail("slurmctld")))
            time.sleep(0.2)

    def _idle(self):
        p = self.client(["sinfo", "-h", "-o", "%T"])
        return p.returncode == 0 and p.stdout.strip() == "idle"

    def log_tail(self, name, lines=15):
        try:
            with open(self.path("log", name + ".out"), errors="replace") as f:
                return "".join(f.readlines()[-lines:])
        except OSError:
            return ""

    def client(self, cmd, timeout=60):
        return subprocess.run(cmd, env=self.env, capture_output=True, text=True, timeout=timeout)

    def queued(self):
        p = self.client(["squeue", "-h", "-o", "%i"])
        return p.stdout.split() if p.returncode == 0 else None

    def stop(self, timeout=60.0):
        """Cancel every job, stop the daemons by PID (SIGTERM, then SIGKILL), kill and return
        whatever else of the cluster was still running; remove the folder."""
        if self.dir is None:
            return []
        if any(name == "slurmctld" and p.poll() is None for name, p in self.procs):
            jobs = sorted({j.split("_")[0] for j in self.queued() or []})
            if jobs:
                self.client(["scancel"] + jobs)
                deadline = time.monotonic() + timeout
                while self.queued() and time.monotonic() < deadline:
                    time.sleep(0.5)
        for _name, proc in reversed(self.procs):
            if proc.poll() is None:
                proc.terminate()
                try:
                    proc.wait(timeout)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
        self.procs = []
        leftovers = self.processes()
        for pid, cmd in leftovers:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        shutil.rmtree(self.dir, ignore_errors=True)
        self.dir = None
        return leftovers

    def processes(self):
        """[(pid, command line)] of the processes started for this cluster, found by their environment."""
        mark = ("ARAP_SLURM_CLUSTER=%s\0" % self.dir).encode()
        found = []
        for pid in os.listdir("/proc"):
            if not pid.isdigit() or int(pid) == os.getpid():
                continue
            try:
                with open("/proc/%s/environ" % pid, "rb") as f:
                    if mark not in f.read() + b"\0":
                        continue
                with open("/proc/%s/cmdline" % pid, "rb") as f:
                    found.append((int(pid), f.read().replace(b"\0", b" ").decode(errors="replace").strip()))
            except OSError:
                continue
        return found


CONF = """\
# A single-node Slurm for arap-batch's tests (blender_tests/slurm_cluster.py).
ClusterName=arap-test
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={dir}/munge/socket
StateSaveLocation={dir}/state
SlurmdSpoolDir={dir}/spool
SlurmctldPidFile={dir}/slurmctld.pid
SlurmdPidFile={dir}/slurmd.pid
SlurmctldLogFile={dir}/log/slurmctld.log
SlurmdLogFile={dir}/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
KillWait=10
{node}
PartitionName=test Nodes={name} Default=YES MaxTime=INFINITE State=UP
"""
