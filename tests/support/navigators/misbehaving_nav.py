"""A navigator process that misbehaves on purpose (standard library only).

Usage: python misbehaving_nav.py MODE. It answers hello and reset properly (unless the mode
says otherwise), then on the first step:
  crash           writes two stderr lines and exits with code 3
  segv            kills itself with SIGSEGV
  hang            sleeps (never answers)
  hang-child      starts a grandchild ``sleep`` in its process group, then sleeps
  setsid-child    starts a grandchild in a new session (escapes the group kill), then sleeps
  setsid-child-pdeathsig   the same, the grandchild with PR_SET_PDEATHSIG (dies with its parent)
  garbage         prints a line that is not JSON
  nan             answers a command with v = NaN
  wrong-type      answers {"type": "ok"} to a step
  slow            answers correctly after 0.3 s
Modes acting before the first step: garbage-hello (prints text instead of hello),
old-protocol (hello with protocol 99), refuse-reset (status error to reset).
"""

import json
import os
import signal
import subprocess
import sys
import time

mode = sys.argv[1]


def send(obj):
    sys.stdout.write((obj if isinstance(obj, str) else json.dumps(obj)) + "\n")
    sys.stdout.flush()


for line in sys.stdin:
    msg = json.loads(line)
    kind = msg["type"]
    if kind == "hello":
        if mode == "garbage-hello":
            send("Hello world! I am a navigator.")
        elif mode == "old-protocol":
            send({"type": "hello", "protocol": 99})
        else:
            send({"type": "hello", "protocol": 1, "name": "misbehaving-" + mode})
    elif kind == "reset":
        if mode == "refuse-reset":
            send({"type": "status", "kind": "error", "message": "mission too long"})
        else:
            send({"type": "ok"})
    elif kind == "step":
        if mode == "crash":
            sys.stderr.write("planner: loading map\nfatal: simulated crash in planner\n")
            sys.stderr.flush()
            sys.exit(3)
        if mode == "segv":
            os.kill(os.getpid(), signal.SIGSEGV)
        if mode == "hang":
            time.sleep(120)
        if mode == "hang-child":
            subprocess.Popen(["sleep", "120"])
            time.sleep(120)
        if mode in ("setsid-child", "setsid-child-pdeathsig"):
            # a helper in a session of its own: out of reach of a process-group kill, unless it
            # asked the kernel to kill it when its parent dies (PR_SET_PDEATHSIG)
            code = "import time; time.sleep(120)"
            if mode == "setsid-child-pdeathsig":
                code = "import ctypes, time; ctypes.CDLL('libc.so.6').prctl(1, 9); " + code
            child = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
            with open(os.environ["HELPER_PID_FILE"], "w") as f:
                f.write(str(child.pid))
            time.sleep(120)
        if mode == "garbage":
            send("[planner] arcs evaluated: 20")
            continue
        if mode == "nan":
            send('{"type": "command", "v": NaN, "omega": 0.0}')
            continue
        if mode == "wrong-type":
            send({"type": "ok"})
            continue
        if mode == "slow":
            time.sleep(0.3)
        send({"type": "command", "v": 0.5, "omega": 0.0})
    elif kind == "close":
        break
