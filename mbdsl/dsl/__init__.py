"""mbdsl.dsl"""
