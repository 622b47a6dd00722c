"""What the Python tests share: running the omnistereo executable and checking its exit code."""
import subprocess
import sys


def runner(exe):
    """A run(*args, expect=0) for `exe`: exits the test with the command's output when its exit
    code is not `expect`; returns the CompletedProcess (text stdout and stderr)."""
    def run(*args, expect=0):
        p = subprocess.run([exe, *args], capture_output=True, text=True)
        if p.returncode != expect:
            sys.exit(f"omnistereo {' '.join(args)}: exit {p.returncode}, expected {expect}\n"
                     f"{p.stdout}{p.stderr}")
        return p
    return run
