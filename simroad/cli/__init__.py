"""simroad.cli"""
