"""widesky.commands: the command-line front ends (app layer), one module per ``widesky`` command.

Each module exposes ``register(subparsers)``; :mod:`widesky.cli` imports only the module of the command run.
"""
