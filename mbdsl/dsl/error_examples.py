"""Common syntax mistakes, recognised by Lark's ``match_examples``.

Each entry maps a diagnostic (code, message, hint) to short malformed
snippets that fail in the same parser state as the user's mistake.
"""

EXAMPLES = {
    ("E104", "a parameter needs '=' before its value", "write 'parameter NAME = value'"): [
        "model m\nparameter a 1",
        "model m\nparameter a (1)",
    ],
    ("E105", "a keyword argument needs '='", "write 'k = 100', not 'k 100'"): [
        "model m\nforce s: spring_damper(a.b, c.d, k 100)",
        "model m\njoint j: point_on_line(a.b, c.d, direction (1, 0))",
    ],
    ("E106", "a joint, force or driver needs ':' after its name",
     "write 'joint NAME: kind(...)'"): [
        "model m\njoint O revolute(a.b, c.d)",
        "model m\nforce s spring_damper(a.b, c.d)",
        "model m\ndriver d crank.phi = t",
    ],
    ("E107", "the file must start with 'model NAME'", "add a first line like 'model my_mechanism'"): [
        "parameter a = 1",
        "body b { mass 1 }",
        "gravity (0, -9.81)",
    ],
}
