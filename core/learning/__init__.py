"""Learned inverse dynamics (thesis sections 2.5 and 4.4): the sliding inverted pendulum's
data (eq. 2.36–2.39), the models (a feed-forward network, a GRU, a Deep Lagrangian Network
with a learned dissipative term) and their one training loop.

Only `models_jax` and `training` import JAX, and only when called (the console starts
without it); `inference` evaluates a trained model's plain weights with numpy, as the
2 ms loop would.
"""
