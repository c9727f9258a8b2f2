"""Build script of the pd_specimen_sim ament_python package."""


from setuptools import find_packages, setup

PACKAGE = 'pd_specimen_sim'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description=('Simulated specimen of the pseudo-dynamic test: answers step commands with '
                 'the restoring force of a hysteresis model.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'main = pd_specimen_sim.node:main',
        ],
    },
)
