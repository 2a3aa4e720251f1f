# tests/data/plugin_pkg is a separate user package with its own test suite: marknav's suite
# runs it in its own pytest process (tests/missions/test_plugins.py), never collects it.
collect_ignore = ["plugin_pkg"]
