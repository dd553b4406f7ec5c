"""simroad.experiments"""
