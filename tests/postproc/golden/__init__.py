"""Golden NC programs of the post-processor tests (see cases.py, regenerate.py)."""
