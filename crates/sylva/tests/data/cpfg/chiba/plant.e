executable: chiba light.spec
communication type: pipes
