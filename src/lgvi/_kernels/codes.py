"""Integer codes shared by the kernels and the Python layer (importing this loads no Numba)."""

METHOD_PAPER = 0
METHOD_NEWTON = 1
METHOD_CAYLEY = 2

OK = 0
NOT_CONVERGED = 1
NOT_FINITE = 2
SINGULAR = 3
OVERFLOW = 4  # the solve converged but the new momentum (or the moment there) is not finite
COLLISION = 6  # the bodies touched, or a body passed through a centre (see contact_kernels)
USER_RAISED = 7  # a user's compiled function raised inside the loop (see user_kernels)
