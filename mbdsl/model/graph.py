"""The body/joint graph (the only module that imports networkx).

Nodes are body indices and ``GROUND``; each joint is an edge (a multigraph,
since two bodies may share several joints). Used for connectivity checks and
to place bodies along a spanning tree before the loops are closed by Newton.
"""

from __future__ import annotations

import networkx as nx

from .elements import GROUND, Model

__all__ = ["body_graph", "bodies_not_connected_to_ground", "spanning_tree_edges",
           "loop_through"]


def body_graph(model: Model) -> nx.MultiGraph:
    """The undirected multigraph of bodies (nodes) and joints (edges).

    Edge attribute ``joint`` holds the :class:`~mbdsl.model.elements.Joint`.
    """
    g = nx.MultiGraph()
    g.add_node(GROUND)
    g.add_nodes_from(range(len(model.bodies)))
    for j in model.joints:
        g.add_edge(j.first.body, j.second.body, joint=j)
    return g


def bodies_not_connected_to_ground(model: Model) -> list[int]:
    """Indices of bodies with no chain of joints to the ground."""
    g = body_graph(model)
    reach = nx.node_connected_component(g, GROUND)
    return [i for i in range(len(model.bodies)) if i not in reach]


def spanning_tree_edges(model: Model) -> list[tuple[int, int, object]]:
    """Breadth-first tree from the ground: (placed body, new body, joint) triples.

    Bodies not reachable from the ground start their own trees (in index
    order) and appear as ``(None, body, None)``.
    """
    g = body_graph(model)
    out, seen = [], set()
    roots = [GROUND] + list(range(len(model.bodies)))
    for root in roots:
        if root in seen:
            continue
        seen.add(root)
        if root != GROUND:
            out.append((None, root, None))
        for parent, child in nx.bfs_edges(g, root):
            seen.add(child)
            data = g.get_edge_data(parent, child)
            joint = data[min(data)]["joint"]
            out.append((parent, child, joint))
    return out


def _body_name(model: Model, b: int) -> str:
    return "ground" if b == GROUND else model.bodies[b].name


def loop_through(model: Model, joint_name: str) -> tuple[list[str], list[str]]:
    """The kinematic loop a joint belongs to: (body names, joint names).

    For a joint outside the spanning tree (:func:`spanning_tree_edges`), its
    fundamental cycle: the tree path between its bodies, closed by it. For a
    tree joint, the shortest fundamental cycle that contains it. ([], [])
    when the joint is on no loop.
    """
    tree = nx.Graph()
    tree_joints = set()
    for parent, child, joint in spanning_tree_edges(model):
        if joint is not None:
            tree.add_edge(parent, child, joint=joint.name)
            tree_joints.add(joint.name)

    def cycle(j):
        """(bodies, joints) of the tree path between j's bodies closed by j, or None."""
        a, b = j.first.body, j.second.body
        if a not in tree or b not in tree or not nx.has_path(tree, a, b):
            return None
        path = nx.shortest_path(tree, a, b)
        joints = [tree.edges[u, v]["joint"] for u, v in zip(path, path[1:])] + [j.name]
        return [_body_name(model, x) for x in path] + [_body_name(model, a)], joints

    by_name = {j.name: j for j in model.joints}
    if joint_name not in by_name:
        return [], []
    if joint_name not in tree_joints:
        return cycle(by_name[joint_name]) or ([], [])
    best = None
    for j in model.joints:
        if j.name in tree_joints:
            continue
        c = cycle(j)
        if c and joint_name in c[1] and (best is None or len(c[1]) < len(best[1])):
            best = c
    return best or ([], [])
