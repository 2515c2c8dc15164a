"""The applied loads' kernels: one module per load family (Q, the triplets of
Q_q, Q_v and Q_lambda, potential energy and power)."""
