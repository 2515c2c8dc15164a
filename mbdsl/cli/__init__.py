"""mbdsl.cli"""
