"""The Viser dashboard: a view of the running system and the operator's buttons. Uses only the
public API of the session in `app`.
"""
