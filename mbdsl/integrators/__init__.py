"""mbdsl.integrators"""
