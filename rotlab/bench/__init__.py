"""``rotlab bench``: work-precision benchmarks of rotlab's methods against scipy's ``solve_ivp``
and the seeds' renormalised RK4 on the same equations, plus throughput and run-time figures.

    problems.py  the problem set, references, error metrics
    peers.py     scipy solve_ivp (RK45, DOP853, LSODA, Radau) and the seeds' RK4, same equations
    runner.py    timing rules, work-precision sweeps, ratios, throughput, cold/warm runs, long runs
    report.py    terminal tables, JSON, PNG plots (matplotlib optional)
    command.py   the typer command ``bench`` (imports inside the function only)
"""
