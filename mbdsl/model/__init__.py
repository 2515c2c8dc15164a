"""mbdsl.model"""
