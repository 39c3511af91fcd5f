"""``drx watch``: a local web page showing a job's car driving, its reward graph and its phase.

:mod:`drx.watch.live` is the only part that runs inside jobs (a small pose file per env);
:mod:`drx.watch.state`, :mod:`drx.watch.frames` and :mod:`drx.watch.server` run in ``drx watch``.
"""
