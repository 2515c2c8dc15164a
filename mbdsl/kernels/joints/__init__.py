"""The joints' kernels: one module per constraint family (Phi, Phi_q^T lambda,
Phi_q v and the triplets of Phi_q, (Phi_q^T lambda)_q, (Phi_q v)_q)."""
