"""System identification: records, excitation signals, the model kinds (GLM, PLM, NLARX, grey-box) and
their registry.
"""
