"""What the tests share that is not a fixture: helpers, hand-made inputs, checkers, and the
programs some tests run as child processes. Imported explicitly, ``from tests.support.X import
...`` (pyproject's ``[tool.pytest.ini_options] pythonpath`` puts the repository root on
``sys.path``; a child process that imports them gets the root on its ``PYTHONPATH``). Fixtures
stay in the ``conftest.py`` files; this package holds no tests (pytest collects ``test_*.py``
only, and there are none here).

- ``built_once``: a session's expensive input built once, also under ``pytest -n``
- ``world_fixtures``, ``sim_worlds``, ``nav_scenes``, ``analysis_synth``: hand-made worlds,
  simulation scenes, navigator scenes, campaign stores and records
- ``cli_inputs``, ``cli_run``, ``stderr_lines``: driving the CLI in process, as a subprocess,
  and on a file, a pipe or a terminal (a script, run as a child)
- ``campaign_kill``, ``leftovers``, ``loopback``, ``live_garbage``: real processes killed and
  looked for, loopback-only network namespaces, a hostile WebSocket client
- ``executor_contract``, ``ray_battery``, ``search_dirs``, ``search_checks``: the executor
  contract, the suite's one Ray cluster, tiny real searches and their checks
- ``trace_check``, ``strict_json``, ``chart_render``, ``junit_schemas``, ``links``: what the
  outputs are held to (MCAP traces, strict JSON, charts drawn by the real renderer, JUnit
  schemas, planted symbolic links)
- ``numba_warm``, ``native_gate``, ``required``, ``nav_plugin_helpers``: the kernels compiled
  once per session, the native walk's skip-or-fail gate, what CI requires, plug-in paths
- ``navigators``: the navigators the tests drive, by target (``tests.support.navigators.
  campaign_navs:Coin``) or as scripts run out of process
"""
