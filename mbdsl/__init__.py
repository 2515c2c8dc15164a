"""mbdsl"""
