"""Build script of the pd_pretest ament_python package."""

from setuptools import find_packages, setup

PACKAGE = 'pd_pretest'

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
    description=("Pre-test planning: the test's model under many records, scales and "
                 "parameters at once, against the bridge's limits, with response spectra."),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'pretest = pd_pretest.pretest:main',
        ],
        'pd.commands': [
            'pretest = pd_pretest.commands:PRETEST',
        ],
    },
)
