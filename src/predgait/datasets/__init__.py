"""Small real trials shipped with predgait (see each folder's README.md for source and license).

Read them through :mod:`predgait.data.bundled`.
"""
