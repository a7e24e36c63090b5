executable: obcheck obstacles.spec
communication type: pipes
