"""Flexible beams: the floating frame of reference's blocks and the elastic
columns of joint points on beams."""
