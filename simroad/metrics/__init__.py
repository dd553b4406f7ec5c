"""simroad.metrics"""
