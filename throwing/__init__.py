"""Throwing: ballistics, the release model, the trained-throw library, generalization to new
targets, Ruckig limiting and the independent limit validator. May import `robot`.
"""
