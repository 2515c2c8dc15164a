"""mbdsl.assembly"""
