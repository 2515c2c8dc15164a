"""Planar Euler-Bernoulli beam meshes for the floating frame of reference.

A beam of length L is cut into N two-node elements of length l = L / N.
Each node j (at arc length x_j = j l) has three nodal coordinates in the
floating frame: the axial displacement u_j, the transverse displacement v_j
and the slope theta_j = dv/dx. Inside an element (xi = (x - x_e) / l):

    u(x) = (1 - xi) u_e + xi u_{e+1}                          (linear)
    v(x) = h1 v_e + l h2 theta_e + h3 v_{e+1} + l h4 theta_{e+1}   (cubic Hermite)
    h1 = 1 - 3 xi^2 + 2 xi^3,  h2 = xi - 2 xi^2 + xi^3,
    h3 = 3 xi^2 - 2 xi^3,      h4 = -xi^2 + xi^3

so a material point at arc length x is at u_bar(x) = (x + u(x), v(x)) in the
frame: u_bar = u_bar0 + S(x) q_f with the shape matrix S (2 x n_f).

Reference conditions remove the three rigid-body modes of the free mesh
(Shabana, Dynamics of Multibody Systems, 4th ed., sec. 5.4-5.6):

* ``first_node`` (default): the frame is attached to the first node,
  origin at the node and x axis along the beam's tangent there
  (u_0 = v_0 = theta_0 = 0). A joint angle on the beam is then the angle of
  its first end's tangent, so a ``fixed`` joint at ``start`` clamps the beam.
* ``chord``: origin at the first node, x axis through the last node
  (u_0 = v_0 = v_N = 0). The reference angle is then the chord's angle; the
  end slopes stay free, the natural choice for a beam pinned at both ends
  like a connecting rod.

Both remove the same three rigid-body motions, so the motion they describe
is the same up to the finite element discretisation; they differ in what the
body's ``x, y, phi`` mean and in how large the elastic coordinates get (for
a rotating beam the chord frame keeps them smallest, which is what the
linear elasticity of the formulation assumes).

Everything here is computed once, at model build. Source: Shabana (above),
sec. 5.4 (element shape functions), 5.5 (inertia shape integrals),
5.6 (reference conditions); Przemieniecki, Theory of Matrix Structural
Analysis, ch. 5 (element stiffness).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BeamMesh", "ModalMesh", "ShapeIntegrals", "FRAMES"]

#: reference conditions: frame name -> removed nodal dofs as (node, component)
#: with component 0 = u, 1 = v, 2 = theta, node -1 the last node
FRAMES = {"first_node": ((0, 0), (0, 1), (0, 2)), "chord": ((0, 0), (0, 1), (-1, 1))}

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)   # exact to degree 7


@dataclass(frozen=True)
class ShapeIntegrals:
    """The inertia shape integrals of a beam (mass per length mu, arc length x).

    Attributes
    ----------
    mass : float [kg]
        m = int mu dx.
    s0 : ndarray, shape (2,) [kg m]
        int mu u_bar0 dx, the undeformed first moment about the frame origin.
    I0 : float [kg m^2]
        int mu u_bar0 . u_bar0 dx.
    S_bar : ndarray, shape (2, nf) [kg]
        int mu S dx.
    M_ff : ndarray, shape (nf, nf) [kg]
        int mu S^T S dx, the elastic mass matrix.
    a_u : ndarray, shape (nf,) [kg m]
        int mu S^T u_bar0 dx.
    a_I : ndarray, shape (nf,) [kg m]
        int mu S^T I~ u_bar0 dx with I~ = [[0, -1], [1, 0]].
    S_tilde : ndarray, shape (nf, nf) [kg]
        int mu S^T I~ S dx (skew-symmetric).
    """

    mass: float
    s0: np.ndarray
    I0: float
    S_bar: np.ndarray
    M_ff: np.ndarray
    a_u: np.ndarray
    a_I: np.ndarray
    S_tilde: np.ndarray


class BeamMesh:
    """A uniform two-node beam mesh with its reference conditions.

    Parameters
    ----------
    length : float [m]
    elements : int
        N >= 1.
    frame : {"first_node", "chord"}
        Reference conditions (module docstring).

    Attributes
    ----------
    nf : int
        Number of elastic coordinates, 3 N.
    kept : ndarray of int, shape (nf,)
        Full nodal dof index (3 node + component) of each elastic coordinate.
    names : list of str, length nf
        ``u1``, ``v1``, ``theta1``, ... (node numbers from 0 at ``start``).

    Raises
    ------
    ValueError
        Non-positive length, fewer than one element or an unknown frame.
    """

    def __init__(self, length: float, elements: int, frame: str = "first_node"):
        if not length > 0:
            raise ValueError(f"beam length must be positive, got {length}")
        if int(elements) != elements or elements < 1:
            raise ValueError(f"a beam needs at least one element, got {elements}")
        if frame not in FRAMES:
            raise ValueError(f"unknown beam frame {frame!r}; use {' or '.join(FRAMES)}")
        self.length, self.elements, self.frame = float(length), int(elements), frame
        self.l = self.length / self.elements
        nodes = self.elements + 1
        removed = {3 * (node % nodes) + comp for node, comp in FRAMES[frame]}
        self.kept = np.array([i for i in range(3 * nodes) if i not in removed], dtype=np.intp)
        self.nf = len(self.kept)
        comp_names = ("u", "v", "theta")
        self.names = [f"{comp_names[i % 3]}{i // 3}" for i in self.kept]

    # -- shape functions ----------------------------------------------------------
    def _element_of(self, x):
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if np.any(x < -1e-12 * self.length) or np.any(x > self.length * (1 + 1e-12)):
            raise ValueError(f"arc length outside the beam [0, {self.length:g}] m")
        e = np.clip((x / self.l).astype(np.intp), 0, self.elements - 1)
        xi = np.clip(x / self.l - e, 0.0, 1.0)
        return x, e, xi

    def _full_shape(self, x):
        """Shape rows on the full nodal vector: (k, 2, 3 (N + 1))."""
        x, e, xi = self._element_of(x)
        l = self.l
        k = len(x)
        S = np.zeros((k, 2, 3 * (self.elements + 1)))
        base = 3 * e
        ar = np.arange(k)
        S[ar, 0, base] = 1.0 - xi
        S[ar, 0, base + 3] = xi
        S[ar, 1, base + 1] = 1.0 - 3 * xi ** 2 + 2 * xi ** 3
        S[ar, 1, base + 2] = l * (xi - 2 * xi ** 2 + xi ** 3)
        S[ar, 1, base + 4] = 3 * xi ** 2 - 2 * xi ** 3
        S[ar, 1, base + 5] = l * (-xi ** 2 + xi ** 3)
        return S

    def shape(self, x) -> np.ndarray:
        """S(x) on the elastic coordinates, shape (k, 2, nf) for k arc lengths [m]."""
        return self._full_shape(x)[:, :, self.kept]

    def slope(self, x) -> np.ndarray:
        """dS_v/dx on the elastic coordinates, shape (k, nf) [1/m, 1]: the
        slope v'(x) of the deflection in the frame is slope(x) . e, the
        rotation of the cross-section at x relative to the frame in the
        linear theory of the formulation (Shabana, Dynamics of Multibody
        Systems, 5.4: the Hermite shape functions' derivatives)."""
        x, e, xi = self._element_of(x)
        l = self.l
        D = np.zeros((len(x), 3 * (self.elements + 1)))
        base, ar = 3 * e, np.arange(len(x))
        D[ar, base + 1] = (-6 * xi + 6 * xi ** 2) / l
        D[ar, base + 2] = 1.0 - 4 * xi + 3 * xi ** 2
        D[ar, base + 4] = (6 * xi - 6 * xi ** 2) / l
        D[ar, base + 5] = -2 * xi + 3 * xi ** 2
        return D[:, self.kept]

    # -- element matrices -----------------------------------------------------------
    def stiffness(self, EA: float, EI: float) -> np.ndarray:
        """Elastic stiffness matrix K on the elastic coordinates, shape (nf, nf) [N/m, N, N m].

        Axial EA/l [[1, -1], [-1, 1]] and the Hermite bending matrix
        EI/l^3 [[12, 6l, -12, 6l], [6l, 4l^2, -6l, 2l^2], ...] per element,
        assembled and reduced by the reference conditions.
        """
        l, N = self.l, self.elements
        K = np.zeros((3 * (N + 1),) * 2)
        ka = EA / l * np.array([[1.0, -1.0], [-1.0, 1.0]])
        kb = EI / l ** 3 * np.array([[12, 6 * l, -12, 6 * l],
                                     [6 * l, 4 * l * l, -6 * l, 2 * l * l],
                                     [-12, -6 * l, 12, -6 * l],
                                     [6 * l, 2 * l * l, -6 * l, 4 * l * l]])
        for e in range(N):      # build time only, N is the element count
            ia = [3 * e, 3 * e + 3]
            ib = [3 * e + 1, 3 * e + 2, 3 * e + 4, 3 * e + 5]
            K[np.ix_(ia, ia)] += ka
            K[np.ix_(ib, ib)] += kb
        return K[np.ix_(self.kept, self.kept)]

    def strain_gradients(self):
        """Per element, the axial strain's gradient and the mean squared slope,
        for the averaged nonlinear axial strain eps_e = u'_e + c_e / 2.

        u'_e = Bu_e q_f (constant in an element: linear u), and c_e = q_f^T G_e
        q_f the mean over the element of v'^2 (cubic Hermite v; three
        Gauss-Legendre points integrate it exactly). The element mean of v'^2,
        not its pointwise value, enters the axial strain: a pointwise v'^2 /
        2 that a linear u cannot follow would leave a spurious axial strain in
        a bent beam and stiffen it (membrane locking: 6 % on a one-element
        cantilever under a tip load); averaged, a bent beam foreshortens
        freely (the tip load's deflection changes only at O((v/L)^2)).
        Hermite slopes dN/dx: (6 xi^2 - 6 xi)/l, 1 - 4 xi + 3 xi^2,
        (6 xi - 6 xi^2)/l, 3 xi^2 - 2 xi.

        Returns
        -------
        Bu : ndarray, shape (N, nf) [1/m]
        G : ndarray, shape (N, nf, nf) [1 / m^2 and 1]
        """
        gx, gw = np.polynomial.legendre.leggauss(3)
        l, N = self.l, self.elements
        xi, w = 0.5 * (gx + 1.0), 0.5 * gw            # on [0, 1]: the mean is sum w f
        full = 3 * (N + 1)
        Bu = np.zeros((N, full))
        G = np.zeros((N, full, full))
        for e in range(N):      # build time only
            b = 3 * e
            Bu[e, b], Bu[e, b + 3] = -1.0 / l, 1.0 / l
            Bv = np.zeros((len(xi), full))
            Bv[:, b + 1] = (6 * xi ** 2 - 6 * xi) / l
            Bv[:, b + 2] = 1 - 4 * xi + 3 * xi ** 2
            Bv[:, b + 4] = (6 * xi - 6 * xi ** 2) / l
            Bv[:, b + 5] = 3 * xi ** 2 - 2 * xi
            G[e] = np.einsum("p,pi,pj->ij", w, Bv, Bv)
        k = self.kept
        return Bu[:, k], G[:, k][:, :, k]

    def quadrature(self):
        """Gauss points and weights over the whole beam: (x, w), each shape (4 N,).

        Four Gauss-Legendre points per element integrate polynomials up to
        degree 7 exactly, which covers every shape integral (degree <= 6).
        """
        e = np.arange(self.elements)[:, None]
        x = (e + 0.5 * (_GAUSS_X[None, :] + 1.0)) * self.l
        w = np.broadcast_to(0.5 * self.l * _GAUSS_W[None, :], x.shape)
        return x.ravel(), w.ravel().copy()

    def shape_integrals(self, mass_per_length: float) -> ShapeIntegrals:
        """The inertia shape integrals for a uniform mass per length [kg/m]."""
        x, w = self.quadrature()
        mu = mass_per_length * w
        S = self.shape(x)                               # (g, 2, nf)
        u0 = np.stack([x, np.zeros_like(x)], axis=1)    # (g, 2)
        Iu0 = np.stack([np.zeros_like(x), x], axis=1)   # I~ u0
        IS = np.stack([-S[:, 1], S[:, 0]], axis=1)      # I~ S
        return ShapeIntegrals(
            mass=float(mu.sum()),
            s0=np.einsum("g,ga->a", mu, u0),
            I0=float(np.einsum("g,ga,ga->", mu, u0, u0)),
            S_bar=np.einsum("g,gaj->aj", mu, S),
            M_ff=np.einsum("g,gai,gaj->ij", mu, S, S),
            a_u=np.einsum("g,gai,ga->i", mu, S, u0),
            a_I=np.einsum("g,gai,ga->i", mu, S, Iu0),
            S_tilde=np.einsum("g,gai,gaj->ij", mu, S, IS),
        )

    def max_translation(self, qf) -> float:
        """Largest nodal translation |u|, |v| [m] of the elastic state qf (nf,)."""
        rows = [i for i, name in enumerate(self.names) if name[0] in "uv"]
        return float(np.max(np.abs(np.asarray(qf)[rows]), initial=0.0))

    def deflection_mid(self, qf) -> np.ndarray:
        """Mid-span transverse deflection relative to the deformed beam's chord [m].

        The signed distance of the material point at x = L/2 from the line
        through the two end points, positive on the frame's +y side:
        cross(p_L - p_0, p_m - p_0) / |p_L - p_0| with p = u_bar0 + S q_f.
        Independent of the frame choice (a rigid motion of the frame changes
        neither length nor sign).

        Parameters
        ----------
        qf : ndarray, shape (nf,) or (N, nf)
            Elastic coordinates.

        Returns
        -------
        float or ndarray, shape (N,)
        """
        qf = np.asarray(qf, dtype=float)
        x = np.array([0.0, 0.5 * self.length, self.length])
        p = np.stack([x, np.zeros(3)], 1) + np.einsum("kaj,...j->...ka", self.shape(x), qf)
        chord = p[..., 2, :] - p[..., 0, :]
        mid = p[..., 1, :] - p[..., 0, :]
        cross = chord[..., 0] * mid[..., 1] - chord[..., 1] * mid[..., 0]
        return cross / np.hypot(chord[..., 0], chord[..., 1])


class ModalMesh:
    """A beam mesh whose transverse (bending) coordinates are reduced to modes:
    q_f = Phi eta.

    The modes are the lowest eigenvectors of K Phi = M_ff Phi Omega^2 of the
    full mesh (its linear stiffness and the elastic mass block of
    :meth:`BeamMesh.shape_integrals`) under the frame's reference
    conditions, computed once at build: with the ``first_node`` frame the
    clamped (cantilever) modes, with ``chord`` those with both ends on the
    chord; the frame's reference conditions play the part of the fixed
    interface of a Craig-Bampton reduction, without its constraint modes
    (Craig & Bampton, AIAA J. 6 (1968) 1313; Shabana, Dynamics of Multibody
    Systems, sec. 5.7: modal coordinates in the floating frame). Each mode is
    scaled so that its largest nodal displacement (a translation, or a slope
    theta times the element length l) is +1 m: eta_i is that amplitude [m].

    Axial (u) and transverse (v, theta) coordinates do not couple in K and
    M_ff, so every mode is one or the other. Without geometric stiffening the
    K lowest modes are kept, whichever they are. With it, the K lowest
    bending modes are kept and the axial nodal coordinates stay as they are:
    the nonlinear axial strain u' + v'^2 / 2 needs an axial displacement that
    follows the foreshortening of every bending shape, which a few axial
    modes cannot (measured on the spin-up beam: with its one static axial
    shape the tip lagged a third of the nodal mesh's lag; with the quartic
    term dropped the beam buckled).

    Every quantity the floating frame needs follows by the same
    transformation, so the formulation is unchanged: S(x) Phi, Phi^T K Phi,
    Phi^T M_ff Phi, Bu Phi and Phi^T G Phi.

    Parameters
    ----------
    mesh : BeamMesh
    modes : int
        K, 1 <= K <= the number of candidate modes (mesh.nf, or its
        transverse coordinates with ``keep_axial``).
    mass_per_length : float [kg/m]
    EA, EI : float [N, N m^2]
    keep_axial : bool
        Reduce the bending coordinates only (geometric stiffening).

    Attributes
    ----------
    nf : int
        K, plus the axial coordinates with ``keep_axial``.
    names : list of str
        ``eta1`` .. ``etaK`` (then ``u1`` .. with ``keep_axial``).
    Phi : ndarray, shape (mesh.nf, nf)
    frequencies : ndarray, shape (K,) [rad/s]
        The modes' natural frequencies (of the linear beam in its frame).

    Raises
    ------
    ValueError
        K outside its range.
    """

    def __init__(self, mesh: BeamMesh, modes: int, mass_per_length: float, EA: float,
                 EI: float, keep_axial: bool = False):
        import scipy.linalg
        axial = np.array([name[0] == "u" for name in mesh.names])
        candidates = np.flatnonzero(~axial) if keep_axial else np.arange(mesh.nf)
        if int(modes) != modes or not 1 <= modes <= len(candidates):
            raise ValueError(f"this beam has 1 to {len(candidates)} modes, got {modes}")
        self.mesh = mesh
        self.length, self.elements, self.frame, self.l = (mesh.length, mesh.elements,
                                                          mesh.frame, mesh.l)
        K = mesh.stiffness(EA, EI)
        M = mesh.shape_integrals(mass_per_length).M_ff
        sub = np.ix_(candidates, candidates)
        w2, Vc = scipy.linalg.eigh(K[sub], M[sub], subset_by_index=(0, int(modes) - 1))
        V = np.zeros((mesh.nf, int(modes)))
        V[candidates] = Vc
        # the largest nodal displacement +1 m, a slope theta counting as theta l
        # (some modes of the chord frame are slopes alone, with no translation)
        measure = np.array([mesh.l if name[0] == "t" else 1.0 for name in mesh.names])
        for i in range(V.shape[1]):
            t = V[:, i] * measure
            V[:, i] /= t[np.argmax(np.abs(t))]
        self.frequencies = np.sqrt(np.maximum(w2, 0.0))
        self.names = [f"eta{i + 1}" for i in range(int(modes))]
        if keep_axial:
            kept = np.flatnonzero(axial)
            unit = np.zeros((mesh.nf, len(kept)))
            unit[kept, np.arange(len(kept))] = 1.0
            V = np.column_stack([V, unit])
            self.names += [mesh.names[i] for i in kept]
        self.Phi = V
        self.nf = V.shape[1]

    def shape(self, x) -> np.ndarray:
        """S(x) Phi, shape (k, 2, nf) for k arc lengths [m]."""
        return self.mesh.shape(x) @ self.Phi

    def slope(self, x) -> np.ndarray:
        """The slope rows of :meth:`BeamMesh.slope` on the modal amplitudes,
        shape (k, nf)."""
        return self.mesh.slope(x) @ self.Phi

    def stiffness(self, EA: float, EI: float) -> np.ndarray:
        """Phi^T K Phi, shape (nf, nf) [N/m]."""
        return self.Phi.T @ self.mesh.stiffness(EA, EI) @ self.Phi

    def strain_gradients(self):
        """(Bu Phi, Phi^T G Phi) of :meth:`BeamMesh.strain_gradients`."""
        Bu, G = self.mesh.strain_gradients()
        return Bu @ self.Phi, np.einsum("ia,eij,jb->eab", self.Phi, G, self.Phi)

    def quadrature(self):
        """The full mesh's Gauss points and weights."""
        return self.mesh.quadrature()

    def shape_integrals(self, mass_per_length: float) -> ShapeIntegrals:
        """The inertia shape integrals in the reduced coordinates."""
        s = self.mesh.shape_integrals(mass_per_length)
        P = self.Phi
        return ShapeIntegrals(mass=s.mass, s0=s.s0, I0=s.I0, S_bar=s.S_bar @ P,
                              M_ff=P.T @ s.M_ff @ P, a_u=P.T @ s.a_u, a_I=P.T @ s.a_I,
                              S_tilde=P.T @ s.S_tilde @ P)

    def nodal(self, eta) -> np.ndarray:
        """The full mesh's elastic coordinates Phi eta, shape (..., mesh.nf)."""
        return np.asarray(eta, dtype=float) @ self.Phi.T

    def max_translation(self, eta) -> float:
        """Largest nodal translation |u|, |v| [m] of the elastic state eta (nf,)."""
        return self.mesh.max_translation(self.nodal(eta))

    def deflection_mid(self, eta) -> np.ndarray:
        """:meth:`BeamMesh.deflection_mid` of the nodal state Phi eta [m]."""
        return self.mesh.deflection_mid(self.nodal(eta))
