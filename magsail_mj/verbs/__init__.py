"""The handlers of the ``magsail`` verbs, one module per group of verbs with the same dependencies.

:mod:`magsail_mj.cli` builds the parser from the standard library alone and its dispatcher imports
a verb's module only when that verb runs, so ``magsail --help`` and ``--version`` load none of
these and ``magsail validate`` loads neither Dask nor Matplotlib nor mediapy. Each handler takes
the parsed arguments and returns the exit status; an unusable input raises
:class:`magsail_mj.cli.CliInputError` (or the library's own refusal), which the dispatcher turns
into one ``error: …`` line and exit status 2.
"""
