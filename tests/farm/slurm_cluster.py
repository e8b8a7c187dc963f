"""A one-node Slurm cluster in a temporary folder: munged, slurmctld and
slurmd (Debian's munge, slurmctld, slurmd, slurm-client), started as root
with their own key, socket, ports, spool and state folders, so nothing of
the machine's /etc/slurm, /etc/munge or /run is used or changed.

    with SlurmCluster(folder) as c:        # raises Unavailable with the reason
        c.env                               # SLURM_CONF for sbatch, squeue, sacct ...

Accounting is off (no slurmdbd); process tracking is Slurm's own
(proctrack/linuxproc, task/none): no cgroups, so it runs in a container or
chroot. Run as a script to start one and keep it until Enter is pressed.
"""
import os
import shutil
import socket
import subprocess
import time

DAEMONS = ("munged", "slurmctld", "slurmd")
CLIENTS = ("sbatch", "squeue", "sinfo", "scontrol")


class Unavailable(Exception):
    """Why the cluster cannot run here (a test skips with it)."""


def _which(name):
    for d in ("/usr/sbin", "/usr/bin", "/sbin", "/bin"):
        if os.access(os.path.join(d, name), os.X_OK):
            return os.path.join(d, name)
    return shutil.which(name)


def _free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _free_ports(n):
    ports = set()
    while len(ports) < n:
        ports.add(_free_port())
    return sorted(ports)


class SlurmCluster:
    def __init__(self, folder, cpus=None):
        self.dir = os.path.abspath(folder)
        self.cpus = cpus or os.cpu_count() or 1
        self.procs = []
        self.env = None

    def __enter__(self):
        if os.geteuid() != 0:
            raise Unavailable("needs root (munged and slurmd run as root here)")
        missing = [n for n in DAEMONS + CLIENTS if not _which(n)]
        if missing:
            raise Unavailable("not installed: %s (scripts/install_deps.sh installs munge, slurmctld, slurmd, "
                              "slurm-client)" % ", ".join(missing))
        try:
            self._start()
            self._probe()
        except Unavailable:
            self.stop()
            raise
        except (OSError, subprocess.SubprocessError) as e:  # a daemon that cannot be run here at all
            self.stop()
            raise Unavailable("cannot start the daemons: %s: %s" % (type(e).__name__, e))
        except Exception:
            self.stop()
            raise
        return self

    def __exit__(self, *exc):
        self.stop()

    def _log(self, name):
        return os.path.join(self.dir, name + ".log")

    def tail(self):
        """The daemons' logs' last lines (for a failure's message)."""
        out = []
        for name in DAEMONS:
            try:
                with open(self._log(name), errors="replace") as f:
                    out.append("--- %s.log\n%s" % (name, "".join(f.readlines()[-15:])))
            except OSError:
                pass
        return "\n".join(out)

    def _start(self):
        d = self.dir
        for sub in ("state", "spool", "run"):
            os.makedirs(os.path.join(d, sub), exist_ok=True)
        os.chmod(d, 0o755)  # munged refuses a socket folder others may write; slurmd's jobs read the config
        key = os.path.join(d, "munge.key")
        with open(key, "wb") as f:
            f.write(os.urandom(128))
        os.chmod(key, 0o600)
        sock = os.path.join(d, "run", "munge.socket")
        self.procs.append(subprocess.Popen(
            [_which("munged"), "--foreground", "--force", "--key-file", key, "--socket", sock,
             "--pid-file", os.path.join(d, "run", "munged.pid"), "--log-file", self._log("munged"),
             "--seed-file", os.path.join(d, "munged.seed")],
            stdout=subprocess.DEVNULL, stderr=open(self._log("munged.err"), "w")))
        self._wait(lambda: os.path.exists(sock), 20, "munged's socket")
        node = socket.gethostname().split(".")[0]
        ctld_port, slurmd_port = _free_ports(2)
        conf = os.path.join(d, "slurm.conf")
        with open(conf, "w") as f:
            f.write("\n".join([
                "ClusterName=iblbake-test",
                "SlurmctldHost=%s(127.0.0.1)" % node,
                "SlurmctldPort=%d" % ctld_port,
                "SlurmdPort=%d" % slurmd_port,
                "SlurmUser=root",
                "SlurmdUser=root",
                "AuthType=auth/munge",
                "CredType=cred/munge",
                "AuthInfo=socket=%s" % sock,
                "StateSaveLocation=%s" % os.path.join(d, "state"),
                "SlurmdSpoolDir=%s" % os.path.join(d, "spool"),
                "SlurmctldPidFile=%s" % os.path.join(d, "run", "slurmctld.pid"),
                "SlurmdPidFile=%s" % os.path.join(d, "run", "slurmd.pid"),
                "SlurmctldLogFile=%s" % self._log("slurmctld"),
                "SlurmdLogFile=%s" % self._log("slurmd"),
                "ProctrackType=proctrack/linuxproc",
                "TaskPlugin=task/none",
                "JobAcctGatherType=jobacct_gather/none",
                "AccountingStorageType=accounting_storage/none",
                "SelectType=select/cons_tres",
                "SelectTypeParameters=CR_Core",
                "MpiDefault=none",
                "ReturnToService=2",
                "SchedulerType=sched/builtin",
                "SlurmctldTimeout=30",
                "SlurmdTimeout=30",
                "InactiveLimit=0",
                "KillWait=5",
                "MinJobAge=3600",
                "NodeName=%s NodeAddr=127.0.0.1 CPUs=%d State=UNKNOWN" % (node, self.cpus),
                "PartitionName=test Nodes=%s Default=YES MaxTime=INFINITE State=UP" % node,
                ""]))
        self.env = dict(os.environ, SLURM_CONF=conf)
        self.procs.append(subprocess.Popen([_which("slurmctld"), "-D", "-i", "-f", conf], env=self.env,
                                           stdout=subprocess.DEVNULL, stderr=open(self._log("slurmctld.err"), "w")))
        self.procs.append(subprocess.Popen([_which("slurmd"), "-D", "-f", conf, "-N", node], env=self.env,
                                           stdout=subprocess.DEVNULL, stderr=open(self._log("slurmd.err"), "w")))

        def idle():
            r = subprocess.run([_which("sinfo"), "-h", "-o", "%T"], env=self.env, capture_output=True, text=True)
            return r.returncode == 0 and r.stdout.strip() in ("idle", "mixed", "allocated")
        self._wait(idle, 60, "the node to be idle")

    def _probe(self, seconds=60):
        """One trivial job, to the end: a node that is idle but cannot launch
        jobs here (slurmstepd refused by the container or chroot) is a reason
        to skip, not a failure of the bake's farm."""
        out = os.path.join(self.dir, "probe.out")
        r = self.run("sbatch", "--parsable", "--job-name=probe", "--output=" + out, "--wrap", "echo probe-ok")
        if r.returncode != 0:
            raise Unavailable("sbatch of a probe job failed: %s\n%s" % (r.stderr.strip(), self.tail()))

        def done():
            try:
                with open(out) as f:
                    return "probe-ok" in f.read()
            except OSError:
                return False
        self._wait(lambda: done() and self.wait_for_jobs(0), seconds, "a probe job (echo) to run")

    def _wait(self, ready, seconds, what):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if ready():
                return
            for p in self.procs:
                if p.poll() is not None:
                    raise Unavailable("%s exited (%d) while waiting for %s:\n%s"
                                      % (os.path.basename(p.args[0]), p.returncode, what, self.tail()))
            time.sleep(0.3)
        raise Unavailable("timed out after %d s waiting for %s:\n%s" % (seconds, what, self.tail()))

    def run(self, *args, **kw):
        return subprocess.run([_which(args[0]), *args[1:]], env=self.env, capture_output=True, text=True, **kw)

    def wait_for_jobs(self, seconds):
        """Until the queue is empty; False on a time-out."""
        end = time.monotonic() + seconds
        while True:
            r = self.run("squeue", "-h", "-o", "%i %T")
            if r.returncode == 0 and not r.stdout.strip():
                return True
            if time.monotonic() >= end:
                return False
            time.sleep(0.5)

    def stop(self):
        for p in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
        for p in reversed(self.procs):
            try:
                p.wait(15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.procs = []


if __name__ == "__main__":
    import tempfile
    with SlurmCluster(tempfile.mkdtemp(prefix="slurm-")) as c:
        print("SLURM_CONF=%s" % c.env["SLURM_CONF"])
        print(c.run("sinfo").stdout)
        input("Enter stops the cluster ")
