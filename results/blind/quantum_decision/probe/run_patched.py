import sys, runpy
sys.path.insert(0, "/tmp/lm")
import finepatch  # noqa: F401  (TIME_QUANTUM from the environment)
script = sys.argv[1]
sys.argv = sys.argv[1:]
runpy.run_path(script, run_name="__main__")
