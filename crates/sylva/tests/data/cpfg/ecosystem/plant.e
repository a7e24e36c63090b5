executable: ecosystem eco.spec
communication type: pipes
