"""A one-node Slurm cluster on this machine for the batch tests: munged with its key, socket and pid in
a temporary folder, slurmctld and slurmd as root on 127.0.0.1 (free ports), one node with this
machine's CPUs and memory, a config written into the same folder and given to every Slurm command by
SLURM_CONF. `start` raises Unavailable with the reason when the cluster cannot run here; `stop` ends
the three daemons it started (by their pid files) and nothing else.

Settings chosen to run without systemd, cgroups or accounting: ProctrackType=proctrack/linuxproc,
TaskPlugin=task/none, JobAcctGatherType=jobacct_gather/none, AccountingStorageType=none,
SelectType=select/cons_tres (CR_CPU)."""

import os
import shutil
import signal
import socket
import subprocess
import time

DAEMONS = ("munged", "slurmctld", "slurmd")
NODE = "quatcurve-node"


class Unavailable(Exception):
    """The cluster cannot start here; the message says why."""


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _program(name):
    for folder in ("/usr/sbin", "/usr/bin"):
        path = os.path.join(folder, name)
        if os.access(path, os.X_OK):
            return path
    return shutil.which(name)


def _memory_mb():
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) // 1024 * 9 // 10  # slurmd refuses a node above what it finds
    return 1024


def _tail(path, lines=3):
    try:
        with open(path, errors="replace") as f:
            return " | ".join(line.strip() for line in f.readlines()[-lines:])
    except OSError:
        return "(no log)"


class Cluster:
    def __init__(self, folder):
        self.folder = str(folder)
        self.conf = os.path.join(self.folder, "slurm.conf")
        self.env = dict(os.environ, SLURM_CONF=self.conf)
        self.pid_files = []

    def path(self, *parts):
        return os.path.join(self.folder, *parts)

    def run(self, *command, timeout=60):
        return subprocess.run(list(command), capture_output=True, text=True, env=self.env, timeout=timeout)

    def start(self, ready_seconds=30):
        missing = [name for name in DAEMONS + ("sinfo", "sbatch", "squeue") if not _program(name)]
        if missing:
            raise Unavailable("%s not installed (Debian packages slurm-wlm and munge: bash build_scripts/setup.sh)"
                              % ", ".join(missing))
        if os.geteuid() != 0:
            raise Unavailable("slurmd must run as root here (this test runs as uid %d)" % os.geteuid())
        for sub in ("munge", "state", "spool"):
            os.makedirs(self.path(sub), mode=0o700, exist_ok=True)
        os.chmod(self.folder, 0o755)  # munged wants its socket's folders searchable by everyone
        key = self.path("munge", "munge.key")
        with open(key, "wb") as f:
            f.write(os.urandom(1024))
        os.chmod(key, 0o400)
        os.chmod(self.path("munge"), 0o755)
        sock = self.path("munge", "munge.socket")
        self._daemon([_program("munged"), "--force", "--socket=" + sock, "--key-file=" + key,
                      "--log-file=" + self.path("munge", "munged.log"), "--pid-file=" + self.path("munge", "munged.pid"),
                      "--seed-file=" + self.path("munge", "munged.seed")], self.path("munge", "munged.pid"),
                     self.path("munge", "munged.log"))
        with open(self.conf, "w") as f:
            f.write(self._config(sock))
        self._daemon([_program("slurmctld"), "-i"], self.path("slurmctld.pid"), self.path("slurmctld.log"))
        self._daemon([_program("slurmd"), "-N", NODE], self.path("slurmd.pid"), self.path("slurmd.log"))
        deadline = time.monotonic() + ready_seconds
        state = ""
        while time.monotonic() < deadline:
            state = self.run("sinfo", "-h", "-N", "-o", "%T").stdout.strip()
            if state == "idle":
                return self
            time.sleep(0.5)
        raise Unavailable("the node is not idle after %d s (sinfo: %r; slurmctld: %s; slurmd: %s)" % (
            ready_seconds, state, _tail(self.path("slurmctld.log")), _tail(self.path("slurmd.log"))))

    def _config(self, sock):
        p = self.path
        return "\n".join([
            "ClusterName=quatcurve", "SlurmctldHost=localhost(127.0.0.1)",
            "SlurmctldPort=%d" % _free_port(), "SlurmdPort=%d" % _free_port(),
            "AuthType=auth/munge", "CredType=cred/munge", "AuthInfo=socket=%s" % sock,
            "SlurmUser=root", "SlurmdUser=root",
            "StateSaveLocation=%s" % p("state"), "SlurmdSpoolDir=%s" % p("spool"),
            "SlurmctldPidFile=%s" % p("slurmctld.pid"), "SlurmdPidFile=%s" % p("slurmd.pid"),
            "SlurmctldLogFile=%s" % p("slurmctld.log"), "SlurmdLogFile=%s" % p("slurmd.log"),
            "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none",
            "JobAcctGatherType=jobacct_gather/none", "AccountingStorageType=accounting_storage/none",
            "SelectType=select/cons_tres", "SelectTypeParameters=CR_CPU", "MpiDefault=none",
            "SwitchType=switch/none", "ReturnToService=2",
            "NodeName=%s NodeHostname=%s NodeAddr=127.0.0.1 CPUs=%d RealMemory=%d State=UNKNOWN"
            % (NODE, socket.gethostname(), os.cpu_count() or 1, _memory_mb()),
            "PartitionName=batch Nodes=ALL Default=YES MaxTime=INFINITE State=UP", ""])

    def _daemon(self, command, pid_file, log):
        proc = subprocess.run(command, capture_output=True, text=True, env=self.env, timeout=60)
        deadline = time.monotonic() + 10
        while proc.returncode == 0 and not os.path.exists(pid_file) and time.monotonic() < deadline:
            time.sleep(0.1)
        if proc.returncode != 0 or not os.path.exists(pid_file):
            raise Unavailable("%s did not start (exit status %d: %s; log: %s)" % (
                os.path.basename(command[0]), proc.returncode, " ".join(proc.stderr.split())[:300], _tail(log)))
        self.pid_files.append(pid_file)

    def wait(self, job, timeout=600):
        """Until the job (every array task) has left the queue."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if not self.run("squeue", "-h", "-j", str(job)).stdout.strip():
                return
            time.sleep(0.5)
        raise TimeoutError("Slurm job %s still queued after %d s" % (job, timeout))

    def stop(self):
        for pid_file in reversed(self.pid_files):
            try:
                with open(pid_file) as f:
                    pid = int(f.read().split()[0])
                os.kill(pid, signal.SIGTERM)
            except (OSError, ValueError, IndexError):
                continue
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline and os.path.exists("/proc/%d" % pid):
                time.sleep(0.1)
        self.pid_files = []
