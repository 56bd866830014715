"""The plant and the compiled one-step kernels every model shares: dynamics, parameter layouts, the
model handle, the sensor.
"""
